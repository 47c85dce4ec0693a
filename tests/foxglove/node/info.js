// Connect and print the serverInfo and the subprotocol the server chose.
"use strict";
const { emit, connect, args, run } = require("./client");

run(async () => {
  const { url, subprotocol } = args();
  const { ws, info } = await connect(url, subprotocol);
  emit("serverInfo", { protocol: ws.protocol, info });
  ws.close();
});
