// JSON lines on stdout and a watchdog, for every script here (the Python tests parse the lines).
//
// A script prints one JSON object a line, {"event": ..., ...}, and ends with {"event": "done"}
// (exit 0), {"event": "error", "message": ...} (exit 2) or {"event": "timeout"} (exit 3, after
// FOXGLOVE_TEST_TIMEOUT seconds, default 20): never a hang.
"use strict";

function emit(event, fields = {}) {
  process.stdout.write(JSON.stringify({ event, ...fields }) + "\n");
}

function finish(code, event, fields = {}) {
  emit(event, fields);
  // exit once stdout is flushed (a pipe may still hold the last lines)
  process.stdout.write("", () => process.exit(code));
}

const seconds = Number(process.env.FOXGLOVE_TEST_TIMEOUT || 20);
setTimeout(() => finish(3, "timeout", { seconds }), seconds * 1000);
process.on("unhandledRejection", (err) => finish(2, "error", { message: String(err?.message ?? err) }));

// Run the async `main` and end with done or error.
function run(main) {
  main().then(
    () => finish(0, "done"),
    (err) => finish(2, "error", { message: String(err?.message ?? err) }),
  );
}

module.exports = { emit, finish, run };
