// BLAKE3 hex digests for uploads: assets are named by their blake3 hash, which Web Crypto does
// not offer. The hashing is the vendored @noble/hashes (vendor/noble-hashes, MIT); the
// coordinator checks every upload's hash, and the dashboard's browser test uploads a mesh.

import { blake3 } from './vendor/noble-hashes/blake3.js';

/// The BLAKE3 hash (32 bytes, no key) of `bytes` (a Uint8Array), lowercase hex.
export function blake3Hex(bytes) {
  return Array.from(blake3(bytes), (b) => b.toString(16).padStart(2, '0')).join('');
}
