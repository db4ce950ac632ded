// Readers of the service's binary bodies (service/binary.py): TMF1 frames (one n x 3
// array: positions or displacements) and TMG1 bundles (several named arrays).

const DTYPES = { float32: Float32Array, float64: Float64Array, uint32: Uint32Array, int32: Int32Array,
  uint8: Uint8Array };

function header(buffer, magic) {
  const bytes = new Uint8Array(buffer);
  const tag = String.fromCharCode(...bytes.slice(0, 4));
  if (tag !== magic) throw new Error(`not a ${magic} body (magic ${tag})`);
  const h = new DataView(buffer).getUint32(4, true);
  return JSON.parse(new TextDecoder().decode(bytes.slice(8, 8 + h)));
}

/** A TMF1 frame: {header, data} with data a typed array of shape header.shape (C order). */
export function decodeFrame(buffer) {
  const head = header(buffer, "TMF1");
  const h = new DataView(buffer).getUint32(4, true);
  const start = 8 + h + ((8 - ((8 + h) % 8)) % 8);
  const n = head.shape.reduce((a, b) => a * b, 1);
  return { header: head, data: new DTYPES[head.dtype](buffer, start, n) };
}

/** A TMG1 bundle: {header, arrays: {name: typed array}} (views, no copies). */
export function decodeBundle(buffer) {
  const head = header(buffer, "TMG1");
  const arrays = {};
  for (const e of head.arrays) {
    const n = e.shape.reduce((a, b) => a * b, 1);
    arrays[e.name] = new DTYPES[e.dtype](buffer, e.offset, n);
  }
  return { header: head, arrays };
}
