// A FoxgloveClient over `ws` for the scenario scripts, run as `node SCRIPT URL SUBPROTOCOL [ARGS...]`
// (their output: see lines.js).
"use strict";
const { FoxgloveClient } = require("@foxglove/ws-protocol");
const { WebSocket } = require("ws");
const { emit, run } = require("./lines");

// Messages from the server, in arrival order, with a way to wait for the next one that matches.
class Inbox {
  constructor(client) {
    this.pending = [];
    this.waiters = [];
    for (const op of ["serverInfo", "parameterValues", "status", "removeStatus"]) {
      client.on(op, (message) => this.push({ op, ...message }));
    }
    client.on("advertise", (channels) => this.push({ op: "advertise", channels }));
  }
  push(message) {
    const waiter = this.waiters.find((w) => w.test(message));
    if (waiter) {
      this.waiters.splice(this.waiters.indexOf(waiter), 1);
      waiter.resolve(message);
    } else {
      this.pending.push(message);
    }
  }
  // The first message (already received or still to come) for which test(message) holds;
  // undefined if none came within `ms` milliseconds (default: wait until the watchdog).
  next(test, ms) {
    const index = this.pending.findIndex(test);
    if (index >= 0) return Promise.resolve(this.pending.splice(index, 1)[0]);
    return new Promise((resolve) => {
      const waiter = { test, resolve };
      this.waiters.push(waiter);
      if (ms !== undefined) {
        setTimeout(() => {
          const at = this.waiters.indexOf(waiter);
          if (at >= 0) this.waiters.splice(at, 1);
          resolve(undefined);
        }, Math.max(0, ms));
      }
    });
  }
  // Everything received so far that nobody waited for (and forget it).
  drain() {
    return this.pending.splice(0);
  }
}

// Connect, offering `subprotocol`; resolves once serverInfo came: {client, ws, inbox, info}.
function connect(url, subprotocol) {
  const ws = new WebSocket(url, [subprotocol]);
  const client = new FoxgloveClient({ ws });
  const inbox = new Inbox(client);
  return new Promise((resolve, reject) => {
    client.on("error", (err) => reject(new Error(`connect ${url} (${subprotocol}): ${err?.message ?? err}`)));
    ws.on("unexpected-response", (_req, res) => reject(new Error(`handshake refused: HTTP ${res.statusCode}`)));
    inbox.next((m) => m.op === "serverInfo").then((info) => resolve({ client, ws, inbox, info }));
  });
}

// The command line every script shares: URL SUBPROTOCOL, then the script's own arguments.
function args() {
  const [url, subprotocol, ...rest] = process.argv.slice(2);
  if (!url || !subprotocol) throw new Error("usage: node SCRIPT URL SUBPROTOCOL [ARGS...]");
  return { url, subprotocol, rest };
}

module.exports = { emit, connect, args, run };
