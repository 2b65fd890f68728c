// A safetensors reader in plain JavaScript (no library), as in docs/binary-format.md.
// `node read_safetensors.mjs answer.safetensors` prints {"fields": {...}, "tensors":
// {name: {"shape": [...], "values": [...]}}} as JSON: JSON.stringify writes each float64 in
// its shortest round-trip form, so the values can be compared bit for bit.
import { readFileSync } from "node:fs";
import { argv } from "node:process";
import { pathToFileURL } from "node:url";

export function readSafetensors(buffer) {
  const view = new DataView(buffer);
  const size = Number(view.getBigUint64(0, true));
  const header = JSON.parse(new TextDecoder().decode(new Uint8Array(buffer, 8, size)));
  const fields = Object.fromEntries(Object.entries(header.__metadata__ ?? {})
    .map(([name, text]) => [name, JSON.parse(text)]));
  delete header.__metadata__;
  const start = 8 + size, tensors = {};
  for (const [name, { dtype, shape, data_offsets: [begin, end] }] of Object.entries(header)) {
    if (dtype !== "F64") throw new Error(`${name}: ${dtype} is not F64`);
    const bytes = buffer.slice(start + begin, start + end);  // a copy: always aligned
    tensors[name] = { shape, values: new Float64Array(bytes) };  // little-endian hosts
  }
  return { tensors, fields };
}

if (import.meta.url === pathToFileURL(argv[1]).href) {
  const file = readFileSync(argv[2]);
  const buffer = file.buffer.slice(file.byteOffset, file.byteOffset + file.byteLength);
  const { tensors, fields } = readSafetensors(buffer);
  const out = {};
  for (const [name, t] of Object.entries(tensors)) out[name] = { shape: t.shape, values: Array.from(t.values) };
  console.log(JSON.stringify({ fields, tensors: out }));
}
