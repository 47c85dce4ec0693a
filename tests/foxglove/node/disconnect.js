// ROUNDS times: connect, send a get-all and PARAMS_JSON as a set, and drop the TCP connection
// at once (no close frame), before any reply can come. Prints {"event": "dropped", "round": N}.
"use strict";
const { emit, connect, args, run } = require("./client");

run(async () => {
  const { url, subprotocol, rest } = args();
  const [rounds, parametersJson] = rest;
  for (let round = 0; round < Number(rounds); round++) {
    const { client, ws } = await connect(url, subprotocol);
    client.getParameters([], `get-${round}`);
    client.setParameters(JSON.parse(parametersJson), `set-${round}`);
    client.subscribeParameterUpdates(JSON.parse(parametersJson).map((p) => p.name));
    await new Promise((resolve) => ws.ping(undefined, undefined, resolve)); // the requests are written
    ws.terminate();
    emit("dropped", { round });
  }
});
