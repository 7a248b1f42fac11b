"""Bundles (`twoscale bundle`, docs/file_contract.md "Bundles" and "Signatures"): a signature checked
first, when a public key is given, then the bundle unpacked and its SHA256SUMS checked.

    from twoscale_tables import Table, bundle
    with bundle.unpacked("twoscale-tables-0.13.0-default.tar.gz", public_key="twoscale.pub") as folder:
        t = Table.open(folder / "epd_g1.h5")     # read inside: the folder is removed on exit
    bundle.status(path)                          # "unsigned" or "signed, not verified" (checksums checked)
    bundle.status(path, public_key=key)          # "signed, verified" (or ", name and version not bound")

`unpacked(path, public_key=None)` yields the bundle's one top-level directory (the tables, bundle.json,
SHA256SUMS) unpacked into a temporary directory; `status(path, public_key=None)` does the same checks and
says what the signature proved. public_key: a minisign `.pub` file (path or text) or its base64 line.
With a key, BUNDLE.tar.gz.minisig beside the bundle is verified before anything of the bundle is read
(none: refused), and bundle.json's version and preset (or scene) must be its trusted comment's. A trusted
comment that is not twoscale's (plain `minisign -Sm` writes its own, and minisign accepts any) is accepted:
the signature covers every byte of the bundle but binds neither its name nor its version, and the status
says so. Without a key a signature beside the bundle is only said ("signed, not verified"). Every refusal
is a ValueError of one line naming the file.
"""
import base64
import binascii
import contextlib
import hashlib
import json
import re
import shutil
import tarfile
import tempfile
from pathlib import Path, PurePosixPath

from cryptography.exceptions import InvalidSignature
from cryptography.hazmat.primitives.asymmetric.ed25519 import Ed25519PublicKey

FORMAT = "twoscale-bundle/1"
PREHASHED = b"ED"  # minisign's algorithm of a bundle's signature: Ed25519 over the file's BLAKE2b-512
COMMENT = re.compile(r"twoscale-bundle/1 file=(?P<file>\S+) version=(?P<version>\S+) (?P<kind>preset|scene)=(?P<name>\S+) "
                     r"versions_lock_sha256=(?P<versions_lock_sha256>[0-9a-fA-F]{64})")
CHUNK = 1 << 20
# manifests/versions.lock as this package's version knows it (a copy; tests/test_bundle.py holds it equal):
# a twoscale signature names the SHA-256 of its version's line, which must be this file's.
VERSIONS_LOCK = Path(__file__).with_name("versions.lock")
__all__ = ["parse_public_key", "parse_signature", "signature_path", "status", "unpacked", "verify_signature",
           "versions_lock_entry_sha256"]


def _b64(text, size, what):
    """The bytes of a base64 line, exactly `size` of them, in its one canonical spelling (b64decode ignores
    the unused bits of the last character: a line differing there would go unchecked)."""
    text = text.encode() if isinstance(text, str) else text
    try:
        raw = base64.b64decode(text, validate=True)
    except (binascii.Error, ValueError):
        raise ValueError(f"{what}: not base64") from None
    if base64.b64encode(raw) != text:
        raise ValueError(f"{what}: not canonical base64")
    if len(raw) != size:
        raise ValueError(f"{what}: {len(raw)} bytes, expected {size}")
    return raw


def _key_hex(key_id):
    return key_id[::-1].hex().upper()  # as minisign prints it: the 8 bytes as a little-endian integer


def parse_public_key(key):
    """(key id, Ed25519PublicKey) of a minisign public key: a `.pub` file's path or text, or its base64
    line (42 bytes: `Ed`, the key id (8), the Ed25519 public key (32))."""
    text, where = str(key), "public key"
    if isinstance(key, Path) or ("\n" not in text and (text.endswith(".pub") or Path(text).is_file())):
        where = text
        try:
            text = Path(text).read_text()
        except (OSError, UnicodeDecodeError) as e:
            raise ValueError(f"cannot read the public key {where}: {getattr(e, 'strerror', None) or e}") from None
    lines = [line.strip() for line in text.strip().splitlines()]
    if len(lines) == 2 and lines[0].startswith("untrusted comment:"):
        lines = lines[1:]
    if len(lines) != 1:
        raise ValueError(f"{where}: not a minisign public key (a comment line and a base64 line, or the base64 line)")
    raw = _b64(lines[0], 42, f"{where}: not a minisign public key")
    if raw[:2] != b"Ed":
        raise ValueError(f"{where}: not a minisign Ed25519 public key (algorithm {raw[:2]!r})")
    return raw[2:10], Ed25519PublicKey.from_public_bytes(raw[10:])


def parse_signature(path, algorithm=PREHASHED):
    """(key id, signature, trusted comment bytes, global signature) of a minisign signature file: four lines,
    `untrusted comment: ...`, base64 of algorithm (2) + key id (8) + signature (64), `trusted comment: TEXT`,
    base64 of the global signature (64); the algorithm must be `algorithm`."""
    try:
        data = Path(path).read_bytes()
    except OSError as e:
        raise ValueError(f"cannot read the signature {path}: {e.strerror}") from None
    if b"\r" in data:
        raise ValueError(f"{path}: CR line endings: a minisign signature's lines end with LF alone")
    lines = data.split(b"\n")
    if lines[-1] == b"":  # the last line's newline
        lines.pop()
    if len(lines) != 4 or not lines[0].startswith(b"untrusted comment: ") or not lines[2].startswith(b"trusted comment: "):
        raise ValueError(f"{path}: not a minisign signature (four lines: untrusted comment, signature, trusted comment, global signature)")
    # The untrusted comment is not signed: only twoscale's and minisign's defaults are read, so that no byte
    # of the file goes unchecked (as the Rust reader).
    if lines[0][len(b"untrusted comment: ") :] not in UNTRUSTED:
        raise ValueError(f"{path}: untrusted comment {lines[0].decode('latin-1')!r} is neither twoscale's nor minisign's default")
    sig = _b64(lines[1], 74, f"{path}: the signature line")
    if sig[:2] != algorithm:
        raise ValueError(f"{path}: signature algorithm {sig[:2].decode('latin-1')!r}, expected {algorithm.decode()!r}")
    comment = lines[2][len(b"trusted comment: ") :]
    return sig[2:10], sig[10:], comment, _b64(lines[3], 64, f"{path}: the global signature line")


UNTRUSTED = (b"signature from twoscale secret key", b"signature from minisign secret key")


def versions_lock_entry_sha256(version, lock=None):
    """The SHA-256 (hex) of `version`'s line `<version> <digest>` in versions.lock's text (default: this
    package's copy), without its newline; None where the version is not recorded."""
    text = VERSIONS_LOCK.read_text() if lock is None else lock
    for line in text.splitlines():
        if line.split(" ", 1)[0] == version and " " in line:
            return hashlib.sha256(line.rstrip().encode()).hexdigest()
    return None


def signature_path(path):
    """BUNDLE.tar.gz.minisig beside the bundle."""
    return Path(path).with_name(Path(path).name + ".minisig")


def verify_signature(path, public_key, copy=None):
    """The trusted comment's fields {file, version, kind ("preset" or "scene"), name, versions_lock_sha256}
    of BUNDLE.tar.gz.minisig, after checking: algorithm ED, the key id, the signature over the bundle's
    BLAKE2b-512, the global signature over signature + trusted comment, and where the comment is twoscale's
    (it starts with FORMAT) its form, its `file` the bundle's own name and its versions_lock_sha256 the
    SHA-256 of the version's line in this package's versions.lock (as `twoscale verify` checks its own); {} for another comment, which
    binds nothing of the bundle but its bytes. `copy`: an open binary file the bundle's bytes are written to as they are hashed
    (read that copy, not the path again: it is what was verified)."""
    path = Path(path)
    sig_path = signature_path(path)
    key_id, key = parse_public_key(public_key)
    if not sig_path.exists():
        raise ValueError(f"{path}: no signature ({sig_path.name} is missing) but a public key was given")
    sig_key, sig, comment, global_sig = parse_signature(sig_path)
    if sig_key != key_id:
        raise ValueError(f"{sig_path}: signed by the key {_key_hex(sig_key)}, not by the public key's {_key_hex(key_id)}")
    digest = hashlib.blake2b(digest_size=64)
    try:
        with open(path, "rb") as f:
            for chunk in iter(lambda: f.read(CHUNK), b""):
                digest.update(chunk)
                if copy is not None:
                    copy.write(chunk)
    except OSError as e:
        raise ValueError(f"cannot read {path}: {e.strerror}") from None
    try:
        key.verify(sig, digest.digest())
    except InvalidSignature:
        raise ValueError(f"{path}: the signature {sig_path.name} does not verify: the bundle is not the one signed") from None
    try:
        key.verify(global_sig, sig + comment)
    except InvalidSignature:
        raise ValueError(f"{sig_path}: the global signature does not verify: the trusted comment is not the one signed") from None
    if not comment.startswith(FORMAT.encode()):
        return {}
    m = COMMENT.fullmatch(comment.decode("utf-8", "replace"))
    if m is None:
        raise ValueError(f"{sig_path}: trusted comment {comment.decode('utf-8', 'replace')!r} is not "
                         f"'{FORMAT} file=... version=... preset=...|scene=... versions_lock_sha256=...'")
    if m["file"] != path.name:
        raise ValueError(f"{sig_path}: signed for the bundle {m['file']}, not {path.name}")
    version, named = m["version"], m["versions_lock_sha256"]
    lock = versions_lock_entry_sha256(version)
    if lock is None:
        raise ValueError(f"{path}: signed for version {version}, which this twoscale_tables' versions.lock does not record: "
                         f"read it with twoscale_tables {version} or newer")
    if named != lock:
        raise ValueError(f"{path}: the signature names versions.lock entry {named} for version {version}, but {lock} is "
                         f"recorded: signed over other data")
    return m.groupdict()


def _extract(f, path, into):
    """Unpacks the tar.gz open in `f` into `into`: directories and regular files only, relative names
    without `..` (nothing can land outside `into` or point elsewhere)."""
    try:
        with tarfile.open(fileobj=f, mode="r:gz") as tar:
            for m in tar:
                name = PurePosixPath(m.name)
                if name.is_absolute() or ".." in name.parts or not name.parts:
                    raise ValueError(f"{path}: entry {m.name!r} is not a relative name inside the bundle")
                target = into.joinpath(*name.parts)
                if m.isdir():
                    target.mkdir(parents=True, exist_ok=True)
                elif m.isfile():
                    target.parent.mkdir(parents=True, exist_ok=True)
                    with tar.extractfile(m) as src, open(target, "wb") as dst:
                        shutil.copyfileobj(src, dst, CHUNK)
                else:
                    raise ValueError(f"{path}: entry {m.name!r} is a link or special file, not a file or directory")
    except (OSError, EOFError, tarfile.TarError) as e:
        raise ValueError(f"{path}: not a readable twoscale bundle ({e})") from None


def _check_sums(path, top):
    """Every file SHA256SUMS names has its SHA-256 (plain names: a file, or a material folder's file)."""
    try:
        sums = (top / "SHA256SUMS").read_text()
    except (OSError, UnicodeDecodeError):
        raise ValueError(f"{path}: not a readable twoscale bundle (no SHA256SUMS)") from None
    for line in sums.splitlines():
        sum_, sep, name = line.partition("  ")
        if not sep:
            raise ValueError(f"{path}: malformed SHA256SUMS line {line!r}")
        parts = name.split("/")
        if len(parts) > 2 or not all(p and not p.startswith(".") and "\\" not in p for p in parts):
            raise ValueError(f"{path}: SHA256SUMS names {name!r}, not a plain file name")
        digest = hashlib.sha256()
        try:
            with open(top.joinpath(*parts), "rb") as f:
                for chunk in iter(lambda: f.read(CHUNK), b""):
                    digest.update(chunk)
        except OSError:
            raise ValueError(f"{path}: {name} is missing") from None
        if digest.hexdigest() != sum_:
            raise ValueError(f"{path}: {name} does not match SHA256SUMS")


def _check_info(path, top, signed):
    """bundle.json's version and preset (or scene) are the trusted comment's."""
    try:
        info = json.loads((top / "bundle.json").read_text())
    except (OSError, UnicodeDecodeError, json.JSONDecodeError) as e:
        raise ValueError(f"{path}: unreadable bundle.json ({e})") from None
    if not isinstance(info, dict) or info.get("format") != FORMAT:
        raise ValueError(f"{path}: bundle.json's format is not {FORMAT}")
    for field, value in (("version", signed["version"]), (signed["kind"], signed["name"])):
        if info.get(field) != value:
            has = repr(info[field]) if field in info else "missing"
            raise ValueError(f"{path}: bundle.json's {field} is {has}, the signature's {value!r}")


@contextlib.contextmanager
def _open(path, public_key):
    """(the bundle's top-level directory, its status), unpacked into a temporary directory removed on exit."""
    path = Path(path)
    signed = None
    try:
        f = open(path, "rb")
    except OSError as e:
        raise ValueError(f"cannot read {path}: {e.strerror}") from None
    with f, tempfile.TemporaryDirectory(prefix="twoscale-bundle-") as tmp:
        into = Path(tmp) / "bundle"
        into.mkdir()
        if public_key is not None:
            # unpack the private copy made as the bundle was hashed: what is unpacked is what was verified
            with open(Path(tmp) / "verified.tar.gz", "w+b") as copy:
                signed = verify_signature(path, public_key, copy)
                copy.seek(0)
                _extract(copy, path, into)
        else:
            _extract(f, path, into)
        dirs = [p for p in into.iterdir() if p.is_dir()]
        if len(dirs) != 1:
            raise ValueError(f"{path}: expected one top-level directory, found {len(dirs)}")
        _check_sums(path, dirs[0])
        if signed:
            _check_info(path, dirs[0], signed)
            said = "signed, verified"
        elif signed is not None:
            said = "signed, verified, name and version not bound"
        else:
            said = "signed, not verified" if signature_path(path).exists() else "unsigned"
        yield dirs[0], said


@contextlib.contextmanager
def unpacked(path, public_key=None):
    """The folder holding the bundle's tables (its one top-level directory), every check passed; removed on exit."""
    with _open(path, public_key) as (top, _):
        yield top


def status(path, public_key=None):
    """"signed, verified" (public_key given), "signed, not verified" or "unsigned", after every check `unpacked` makes."""
    with _open(path, public_key) as (_, said):
        return said
