// Subscribe to the channel advertised as TOPIC and print each of its messages for SECONDS:
// {"event": "advertised", "channel": ...}, then {"event": "message", "data": ...} (JSON decoded).
"use strict";
const { emit, connect, args, run } = require("./client");

run(async () => {
  const { url, subprotocol, rest } = args();
  const [topic, seconds] = rest;
  const { client, ws, inbox } = await connect(url, subprotocol);
  const advertised = await inbox.next((m) => m.op === "advertise" && m.channels.some((c) => c.topic === topic));
  const channel = advertised.channels.find((c) => c.topic === topic);
  emit("advertised", { channel });
  const decoder = new TextDecoder();
  client.on("message", ({ data }) => emit("message", { data: JSON.parse(decoder.decode(data)) }));
  client.subscribe(channel.id);
  await new Promise((resolve) => setTimeout(resolve, Number(seconds) * 1000));
  ws.close();
});
