// subscribeParameterUpdates(NAMES...), then print every update for SECONDS.
// Prints {"event": "subscribed"} once the server has handled the subscription (a get answered
// after it), then {"event": "update", "message": ...} for each parameterValues without an id.
"use strict";
const { emit, connect, args, run } = require("./client");

run(async () => {
  const { url, subprotocol, rest } = args();
  const [seconds, ...names] = rest;
  const { client, ws, inbox } = await connect(url, subprotocol);
  client.subscribeParameterUpdates(names);
  client.getParameters(names, "subscribed");
  emit("subscribed", { message: await inbox.next((m) => m.op === "parameterValues" && m.id === "subscribed") });
  const end = Date.now() + Number(seconds) * 1000;
  while (Date.now() < end) {
    const message = await inbox.next((m) => m.op === "parameterValues" && m.id === undefined, end - Date.now());
    if (message) emit("update", { message });
  }
  ws.close();
});
