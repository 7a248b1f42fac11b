// verify.js: fetching a `twoscale export --format webgl` export's files and verifying them (runtimes/webgl/README.md):
// each file's HTTP status, SHA256SUMS against the descriptor's digests, and the minisign signature of SHA256SUMS
// (docs/file_contract.md "Signatures"). Shared by the material loader (twoscale.js) and the general one
// (twoscale_general.js); twoscale.js re-exports it.

export async function fetchOk(url, name) {
  let res;
  try {
    res = await fetch(url, { cache: 'no-store' });
  } catch (e) {
    throw new Error(`${name}: ${e.message}`);
  }
  if (!res.ok) throw new Error(`${name}: HTTP ${res.status}`);
  return res;
}

export const hex = (buf) => Array.from(new Uint8Array(buf), (b) => b.toString(16).padStart(2, '0')).join('');

// The export's SHA256SUMS (`sha256sum -c` format): the descriptor's digest (nothing else covers its numbers: a changed
// digit in beta would render silently), and each table's line the same as the descriptor's sha256. Unsigned, it is
// fetched here after the binaries, so that their own errors come first; signed, sums are the bytes verifySignature
// verified (a second fetch could return others), checked before any binary is fetched.
export async function checkSums(base, descName, descBytes, entries, sums = null) {
  const file = 'SHA256SUMS';
  const text = new TextDecoder().decode(sums ?? (await (await fetchOk(new URL(file, base), file)).arrayBuffer()));
  const lines = {};
  for (const line of text.split('\n')) {
    const m = /^([0-9a-f]{64}) [ *](.+)$/.exec(line);
    if (m) lines[m[2]] = m[1];
    else if (line.trim()) throw new Error(`${file}: not a sha256sum line: ${JSON.stringify(line.slice(0, 80))}`);
  }
  const got = hex(await crypto.subtle.digest('SHA-256', descBytes));
  if (lines[descName] !== got) throw new Error(`${descName}: SHA-256 mismatch (${file} has ${lines[descName] ?? 'no line for it'}, got ${got})`);
  for (const e of entries) {
    if (lines[e.file] !== e.sha256.toLowerCase()) throw new Error(`${e.file}: ${file} has ${lines[e.file] ?? 'no line for it'}, ${descName} ${e.sha256}`);
  }
}

// Strict base64 (atob also takes whitespace, missing padding and set unused bits): bytes, or null; only the one
// canonical spelling of the bytes, so that no character of a signature file goes unchecked.
function base64(s) {
  if (s.length % 4 || !/^[A-Za-z0-9+/]*={0,2}$/.test(s)) return null;
  const raw = atob(s);
  return btoa(raw) === s ? Uint8Array.from(raw, (c) => c.charCodeAt(0)) : null;
}

// A minisign key id as minisign prints it (the 8 bytes little-endian, in hex).
const keyId = (b) => hex(b.slice().reverse()).toUpperCase();
const UNTRUSTED = ['signature from twoscale secret key', 'signature from minisign secret key'];

// The export's signature (docs/file_contract.md "Signatures"): SHA256SUMS.minisig beside the export, by publicKey (a
// minisign public key: a .pub file's text or its base64 line), over SHA256SUMS's bytes, algorithm Ed (Ed25519 over the
// file itself: browsers have no BLAKE2b for minisign's prehashed ED), the global signature over the signature and the
// trusted comment, which must start `twoscale-export/1 `. Rejects with an Error naming the key or the file; resolves to
// { sums: SHA256SUMS's bytes, for checkSums, comment: the trusted comment, for expectComment }. Called before anything
// else of the export is fetched.
export async function verifySignature(base, publicKey) {
  if (typeof publicKey !== 'string') throw new Error(`publicKey: not a string (a minisign public key: a .pub file's text or its base64 line)`);
  const keyLines = publicKey.split('\n').map((l) => l.trim()).filter((l) => l && !l.startsWith('untrusted comment:'));
  const pk = keyLines.length === 1 ? base64(keyLines[0]) : null;
  if (!pk || pk.length !== 42 || pk[0] !== 0x45 || pk[1] !== 0x64) {
    throw new Error(`publicKey: not a minisign public key (one base64 line of 42 bytes: "Ed", the key id, the Ed25519 key)`);
  }
  const sigFile = 'SHA256SUMS.minisig';
  if (!globalThis.crypto?.subtle) throw new Error(`${sigFile}: cannot verify: SubtleCrypto needs a secure context (https, or http on localhost/127.0.0.1)`);
  let key;
  try {
    key = await crypto.subtle.importKey('raw', pk.subarray(10), { name: 'Ed25519' }, false, ['verify']);
  } catch (e) {
    // a browser without WebCrypto's Ed25519 cannot check the signature: refused, never skipped
    if (e.name === 'NotSupportedError') throw new Error(`${sigFile}: cannot verify: this browser's SubtleCrypto has no Ed25519 (${e.message})`);
    throw new Error(`publicKey: not an Ed25519 public key (${e.message})`);
  }
  let res;
  try {
    res = await fetchOk(new URL(sigFile, base), sigFile);
  } catch (e) {
    throw new Error(`${e.message} (a public key was given: the export must be signed)`);
  }
  const bad = (why) => new Error(`${sigFile}: not a minisign signature (${why})`);
  let text;
  try {
    text = new TextDecoder('utf-8', { fatal: true, ignoreBOM: true }).decode(await res.arrayBuffer());  // a BOM stays, and is refused
  } catch {
    throw bad('not UTF-8');
  }
  if (text.includes('\r')) throw bad('CR line endings: its lines end with LF alone');
  const lines = text.split('\n');
  if (lines.at(-1) === '') lines.pop();
  if (lines.length !== 4) throw bad(`${lines.length} lines, expected 4`);
  if (!lines[0].startsWith('untrusted comment: ')) throw bad('line 1 is not its untrusted comment');
  // not signed: only twoscale's and minisign's defaults are read, so that no byte of the file goes unchecked
  if (!UNTRUSTED.includes(lines[0].slice('untrusted comment: '.length))) throw bad('its untrusted comment is neither twoscale\'s nor minisign\'s default');
  if (!lines[2].startsWith('trusted comment: ')) throw bad('line 3 is not its trusted comment');
  const sig = base64(lines[1]), global = base64(lines[3]);
  if (!sig || sig.length !== 74) throw bad('line 2 is not base64 of 74 bytes');
  if (!global || global.length !== 64) throw bad('line 4 is not base64 of 64 bytes');
  const alg = String.fromCharCode(sig[0], sig[1]);
  if (alg === 'ED') throw new Error(`${sigFile}: algorithm ED (Ed25519 over the file's BLAKE2b-512), which browsers cannot check (no BLAKE2b in SubtleCrypto): an export is signed with Ed (minisign -S -l)`);
  if (alg !== 'Ed') throw new Error(`${sigFile}: algorithm ${JSON.stringify(alg)}, expected Ed`);
  if (keyId(sig.subarray(2, 10)) !== keyId(pk.subarray(2, 10))) {
    throw new Error(`${sigFile}: signed by key ${keyId(sig.subarray(2, 10))}, not by the public key given (${keyId(pk.subarray(2, 10))})`);
  }
  const sumsFile = 'SHA256SUMS';
  const sums = new Uint8Array(await (await fetchOk(new URL(sumsFile, base), sumsFile)).arrayBuffer());
  if (!(await crypto.subtle.verify('Ed25519', key, sig.subarray(10), sums))) {
    throw new Error(`${sigFile}: the signature does not verify: ${sumsFile} is not the file the key signed`);
  }
  // the global signature: over the signature and the trusted comment's UTF-8 (a comment that is not UTF-8 fails it)
  const comment = lines[2].slice('trusted comment: '.length), utf8 = new TextEncoder().encode(comment);
  const signed = new Uint8Array(64 + utf8.length);
  signed.set(sig.subarray(10));
  signed.set(utf8, 64);
  if (!(await crypto.subtle.verify('Ed25519', key, global, signed))) {
    throw new Error(`${sigFile}: the global signature does not verify: the trusted comment is not the one the key signed`);
  }
  if (!comment.startsWith('twoscale-export/1 ')) {
    throw new Error(`${sigFile}: trusted comment ${JSON.stringify(comment.slice(0, 80))} is not a twoscale export's (twoscale-export/1 ...)`);
  }
  return { sums, comment };
}

// A verified signature's trusted comment must name this export (`twoscale-export/1 version=V material=NAME` or
// `preset=default`, V the descriptor's generator version): a signature cannot be moved to another export or version.
export function expectComment(signed, descriptor, what) {
  const want = `twoscale-export/1 version=${descriptor.generator?.version} ${what}`;
  if (signed.comment !== want) {
    throw new Error(`SHA256SUMS.minisig: signed for ${JSON.stringify(signed.comment)}, not this export (${JSON.stringify(want)})`);
  }
}

// The loaders' options, { publicKey }: with a key (given even as undefined: verified, never skipped) what
// verifySignature returns; without, null.
export async function signedSums(base, opts, caller) {
  const o = opts ?? {};
  const extra = typeof o === 'object' ? Object.keys(o).filter((k) => k !== 'publicKey') : [JSON.stringify(o)];
  if (extra.length) throw new Error(`${caller}: unknown option ${extra.join(', ')} (publicKey)`);
  return 'publicKey' in o ? verifySignature(base, o.publicKey) : null;
}
