// BLAKE3 (the hash of the BLAKE3 specification, default 32-byte output, no key): assets are
// uploaded under their blake3 hash, which Web Crypto does not offer. Whole-buffer form of the
// specification's reference implementation; the coordinator checks every upload's hash, and the
// dashboard's browser test uploads a mesh through it.

const IV = Uint32Array.of(
  0x6a09e667, 0xbb67ae85, 0x3c6ef372, 0xa54ff53a, 0x510e527f, 0x9b05688c, 0x1f83d9ab, 0x5be0cd19);
const PERMUTATION = [2, 6, 3, 10, 7, 0, 4, 13, 1, 11, 12, 5, 9, 14, 15, 8];
const CHUNK_START = 1;
const CHUNK_END = 2;
const PARENT = 4;
const ROOT = 8;
const BLOCK_LEN = 64;
const CHUNK_LEN = 1024;

function g(s, a, b, c, d, x, y) {
  s[a] = s[a] + s[b] + x;
  s[d] = rotr(s[d] ^ s[a], 16);
  s[c] = s[c] + s[d];
  s[b] = rotr(s[b] ^ s[c], 12);
  s[a] = s[a] + s[b] + y;
  s[d] = rotr(s[d] ^ s[a], 8);
  s[c] = s[c] + s[d];
  s[b] = rotr(s[b] ^ s[c], 7);
}

function rotr(x, n) {
  return (x >>> n) | (x << (32 - n));
}

/// The compression function: 16 words of output.
function compress(cv, block, counter, blockLen, flags) {
  const s = new Uint32Array(16);
  s.set(cv, 0);
  s.set(IV.subarray(0, 4), 8);
  s[12] = counter % 0x100000000;
  s[13] = Math.floor(counter / 0x100000000);
  s[14] = blockLen;
  s[15] = flags;
  let m = Uint32Array.from(block);
  for (let round = 0; round < 7; round++) {
    g(s, 0, 4, 8, 12, m[0], m[1]);
    g(s, 1, 5, 9, 13, m[2], m[3]);
    g(s, 2, 6, 10, 14, m[4], m[5]);
    g(s, 3, 7, 11, 15, m[6], m[7]);
    g(s, 0, 5, 10, 15, m[8], m[9]);
    g(s, 1, 6, 11, 12, m[10], m[11]);
    g(s, 2, 7, 8, 13, m[12], m[13]);
    g(s, 3, 4, 9, 14, m[14], m[15]);
    if (round < 6) m = Uint32Array.from(PERMUTATION, (i) => m[i]);
  }
  for (let i = 0; i < 8; i++) {
    s[i] ^= s[i + 8];
    s[i + 8] ^= cv[i];
  }
  return s;
}

/// Up to 64 bytes as 16 little-endian words, zero-padded.
function blockWords(bytes, start, len) {
  const padded = new Uint8Array(BLOCK_LEN);
  padded.set(bytes.subarray(start, start + len));
  const view = new DataView(padded.buffer);
  return Uint32Array.from({ length: 16 }, (_, i) => view.getUint32(4 * i, true));
}

/// The last compression of a node, not yet done: its inputs.
function chunkOutput(bytes, start, len, counter) {
  let cv = IV;
  const blocks = Math.max(1, Math.ceil(len / BLOCK_LEN));
  for (let b = 0; b < blocks; b++) {
    const blockLen = Math.min(BLOCK_LEN, len - b * BLOCK_LEN);
    const flags = (b === 0 ? CHUNK_START : 0) | (b === blocks - 1 ? CHUNK_END : 0);
    const words = blockWords(bytes, start + b * BLOCK_LEN, blockLen);
    if (b === blocks - 1) return { cv, words, counter, blockLen, flags };
    cv = compress(cv, words, counter, blockLen, flags).subarray(0, 8);
  }
  throw new Error('unreachable');
}

function chainingValue(out) {
  return compress(out.cv, out.words, out.counter, out.blockLen, out.flags).subarray(0, 8);
}

function parentOutput(left, right) {
  const words = new Uint32Array(16);
  words.set(left, 0);
  words.set(right, 8);
  return { cv: IV, words, counter: 0, blockLen: BLOCK_LEN, flags: PARENT };
}

/// The blake3 hash of `bytes` (a Uint8Array) as 64 lowercase hex digits.
export function blake3Hex(bytes) {
  const chunks = Math.max(1, Math.ceil(bytes.length / CHUNK_LEN));
  const stack = [];
  for (let c = 0; c < chunks - 1; c++) {
    let cv = chainingValue(chunkOutput(bytes, c * CHUNK_LEN, CHUNK_LEN, c));
    // Merge finished subtrees: as many as the chunk count so far has trailing zero bits.
    for (let total = c + 1; (total & 1) === 0; total >>= 1) {
      cv = chainingValue(parentOutput(stack.pop(), cv));
    }
    stack.push(cv);
  }
  const lastStart = (chunks - 1) * CHUNK_LEN;
  let out = chunkOutput(bytes, lastStart, bytes.length - lastStart, chunks - 1);
  while (stack.length) out = parentOutput(stack.pop(), chainingValue(out));
  const root = compress(out.cv, out.words, 0, out.blockLen, out.flags | ROOT);
  let hex = '';
  for (let i = 0; i < 8; i++) {
    const w = root[i];
    for (let k = 0; k < 4; k++) hex += ((w >>> (8 * k)) & 0xff).toString(16).padStart(2, '0');
  }
  return hex;
}
