// setParameters(PARAMS_JSON) with an id, then a get of the same names as a barrier.
// Prints the set's reply, every status that came before the barrier's reply, and that reply.
"use strict";
const { emit, connect, args, run } = require("./client");

run(async () => {
  const { url, subprotocol, rest } = args();
  const parameters = JSON.parse(rest[0]);
  const { client, ws, inbox } = await connect(url, subprotocol);
  client.setParameters(parameters, "set-1");
  emit("reply", { message: await inbox.next((m) => m.op === "parameterValues" && m.id === "set-1") });
  client.getParameters(parameters.map((p) => p.name), "after-set");
  const after = await inbox.next((m) => m.op === "parameterValues" && m.id === "after-set");
  for (const message of inbox.drain()) if (message.op === "status") emit("status", { message });
  emit("after", { message: after });
  ws.close();
});
