// Runs the compiled client (out/client.js) against a server: node run.mjs URL URDF_FILE.
// Prints the client's summary as JSON (tests/typescript/test_typescript_client.py reads it).
import { readFileSync } from "node:fs";
import { run } from "./out/client.js";

const [base, urdfPath] = process.argv.slice(2);
const summary = await run(base, readFileSync(urdfPath, "utf8"));
console.log(JSON.stringify(summary));
