// Read an MCAP file with @mcap/core's McapStreamReader (zstd and lz4 from @mcap/support) and
// print what it holds: {"event": "channel", "id", "topic", "schema", "encoding"} per channel,
// {"event": "message", "topic", "log_time" (a string: nanoseconds), "data" (the JSON message)}
// per message, then {"event": "end", "complete": <a whole file, footer included>, "remaining":
// <bytes of a torn tail left unparsed>}. Usage: node read_mcap.js FILE.mcap
"use strict";
const fs = require("node:fs");
const { McapStreamReader } = require("@mcap/core");
const { loadDecompressHandlers } = require("@mcap/support");
const { emit, run } = require("./lines");

run(async () => {
  const path = process.argv[2];
  if (!path) throw new Error("usage: node read_mcap.js FILE.mcap");
  const reader = new McapStreamReader({ decompressHandlers: await loadDecompressHandlers() });
  reader.append(fs.readFileSync(path));
  const topics = new Map();
  const schemas = new Map();
  const text = new TextDecoder();
  for (let record; (record = reader.nextRecord()); ) {
    if (record.type === "Schema") {
      schemas.set(record.id, { name: record.name, encoding: record.encoding });
    } else if (record.type === "Channel") {
      topics.set(record.id, record.topic);
      const schema = schemas.get(record.schemaId) ?? {};
      emit("channel", {
        id: record.id,
        topic: record.topic,
        encoding: record.messageEncoding,
        schema: schema.name,
        schema_encoding: schema.encoding,
      });
    } else if (record.type === "Message") {
      emit("message", {
        topic: topics.get(record.channelId),
        log_time: record.logTime.toString(),
        data: JSON.parse(text.decode(record.data)),
      });
    }
  }
  emit("end", { complete: reader.done(), remaining: reader.bytesRemaining() });
});
