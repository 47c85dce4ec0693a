// getParameters(NAMES...) (none: all) and print the reply: {"event": "reply", "message": ...}.
"use strict";
const { emit, connect, args, run } = require("./client");

run(async () => {
  const { url, subprotocol, rest: names } = args();
  const { client, ws, inbox } = await connect(url, subprotocol);
  client.getParameters(names, "get-1");
  emit("reply", { message: await inbox.next((m) => m.op === "parameterValues" && m.id === "get-1") });
  ws.close();
});
