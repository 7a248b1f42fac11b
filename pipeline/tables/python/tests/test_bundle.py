"""twoscale_tables.bundle on small bundles made here (a top directory with one tiny table file, bundle.json and
SHA256SUMS, as docs/file_contract.md "Bundles") and signed by Debian's minisign 0.11: a good signature
verifies, and every refusal of the contract's "Signatures" is one ValueError naming the file."""
import base64
import gzip
import hashlib
import io
import json
import shutil
import subprocess
import tarfile
from pathlib import Path

import pytest
from twoscale_tables import bundle

REPO = Path(__file__).resolve().parents[4]
# The newest version manifests/versions.lock records, and versions_lock_sha256: the SHA-256 of its line (computed
# here from the file, not by the reader).
_LINE = [line for line in (REPO / "manifests/versions.lock").read_text().splitlines() if line and not line.startswith("#")][-1]
VERSION, PRESET = _LINE.split(" ")[0], "default"
NAME = f"twoscale-tables-{VERSION}-{PRESET}.tar.gz"
LOCK = hashlib.sha256(_LINE.encode()).hexdigest()


def comment(file=NAME, version=VERSION, target=f"preset={PRESET}", lock=LOCK):
    return f"twoscale-bundle/1 file={file} version={version} {target} versions_lock_sha256={lock}"


def minisign(*args, cwd):
    if shutil.which("minisign") is None:
        pytest.fail("minisign is missing (`make deps` installs Debian's)")
    res = subprocess.run(["minisign", *args], cwd=cwd, capture_output=True, text=True, stdin=subprocess.DEVNULL)
    assert res.returncode == 0, res.stderr


@pytest.fixture(scope="session")
def keys(tmp_path_factory):
    """Two unencrypted minisign key pairs: {name: (secret key path, public key path)}."""
    d = tmp_path_factory.mktemp("keys")
    for name in ("k", "other"):
        minisign("-G", "-W", "-f", "-p", f"{name}.pub", "-s", f"{name}.key", cwd=d)
    return {name: (d / f"{name}.key", d / f"{name}.pub") for name in ("k", "other")}


def make_bundle(folder, name=NAME, table=b"\x00\x01table bytes\x02", info=None, sums=None):
    """NAME under folder: top directory t.h5, bundle.json, SHA256SUMS (of the files, or `sums`)."""
    info = info or {"format": "twoscale-bundle/1", "version": VERSION, "generator": {"name": "test", "version": VERSION},
                    "preset": PRESET, "tables": []}
    files = {"bundle.json": json.dumps(info).encode(), "t.h5": table}
    files["SHA256SUMS"] = sums or "".join(f"{hashlib.sha256(b).hexdigest()}  {n}\n" for n, b in sorted(files.items())).encode()
    return write_tar(folder / name, {f"{name[: -len('.tar.gz')]}/{n}": b for n, b in files.items()})


def write_tar(path, files, extra=()):
    """A .tar.gz of {entry name: bytes} and the tar headers `extra` (no data)."""
    raw = io.BytesIO()
    with tarfile.open(fileobj=raw, mode="w") as tar:
        for n, b in files.items():
            info = tarfile.TarInfo(n)
            info.size = len(b)
            tar.addfile(info, io.BytesIO(b))
        for info in extra:
            tar.addfile(info)
    path.write_bytes(gzip.compress(raw.getvalue()))
    return path


def sign(path, key, text=None, legacy=False):
    """PATH.minisig by minisign (-l: the legacy algorithm Ed)."""
    minisign("-S", *(["-l"] if legacy else []), "-s", str(key), "-m", path.name, "-t", text or comment(file=path.name), cwd=path.parent)
    return bundle.signature_path(path)


def refusal(path, key, needle):
    """The ValueError unpacking PATH with KEY gives: one line, naming the file, holding `needle`."""
    with pytest.raises(ValueError) as e:
        with bundle.unpacked(path, public_key=key):
            pass
    msg = str(e.value)
    assert "\n" not in msg and path.name in msg and needle in msg, msg
    return msg


def test_good_signature_verifies(tmp_path, keys):
    path = make_bundle(tmp_path)
    sign(path, keys["k"][0])
    pub = keys["k"][1]
    line = pub.read_text().splitlines()[1]
    for key in (pub, str(pub), pub.read_text(), line):  # a .pub path, its text, its base64 line
        assert bundle.status(path, public_key=key) == "signed, verified"
    with bundle.unpacked(path, public_key=pub) as folder:
        assert folder.name == NAME[: -len(".tar.gz")]
        assert (folder / "t.h5").read_bytes() == b"\x00\x01table bytes\x02"
        assert json.loads((folder / "bundle.json").read_text())["version"] == VERSION
    assert not folder.exists()  # removed on exit


def test_statuses_without_a_key(tmp_path, keys):
    path = make_bundle(tmp_path)
    assert bundle.status(path) == "unsigned"
    sign(path, keys["k"][0])
    assert bundle.status(path) == "signed, not verified"
    # Without a key the checksums are still checked.
    make_bundle(tmp_path, sums=b"0" * 64 + b"  t.h5\n")
    refusal(path, None, "t.h5 does not match SHA256SUMS")


def test_changed_bundle_refused(tmp_path, keys):
    path = make_bundle(tmp_path)
    sign(path, keys["k"][0])
    data = bytearray(path.read_bytes())
    data[len(data) // 2] ^= 0x01
    path.write_bytes(bytes(data))
    refusal(path, keys["k"][1], "does not verify: the bundle is not the one signed")
    # A table changed and SHA256SUMS rewritten to match: the checksums pass, the signature does not.
    make_bundle(tmp_path, table=b"\x00\x01forged bytes\x02")
    assert bundle.status(path) == "signed, not verified"
    refusal(path, keys["k"][1], "does not verify: the bundle is not the one signed")


def test_other_key_refused(tmp_path, keys):
    path = make_bundle(tmp_path)
    sig = sign(path, keys["other"][0])
    refusal(path, keys["k"][1], "not by the public key's")
    # The other key's signature relabelled with this key's id: the signature itself fails.
    key_id = base64.b64decode(keys["k"][1].read_text().splitlines()[1])[2:10]
    lines = sig.read_text().splitlines()
    raw = base64.b64decode(lines[1])
    lines[1] = base64.b64encode(raw[:2] + key_id + raw[10:]).decode()
    sig.write_text("\n".join(lines) + "\n")
    refusal(path, keys["k"][1], "does not verify")


def test_signature_of_another_bundle_refused(tmp_path, keys):
    other = make_bundle(tmp_path, name=f"twoscale-tables-{VERSION}-paper.tar.gz")
    sign(other, keys["k"][0])
    # The same bytes and signature under this bundle's name: the trusted comment names the other file.
    path = tmp_path / NAME
    shutil.copy(other, path)
    shutil.copy(bundle.signature_path(other), bundle.signature_path(path))
    refusal(path, keys["k"][1], f"signed for the bundle {other.name}, not {NAME}")


def test_changed_trusted_comment_refused(tmp_path, keys):
    path = make_bundle(tmp_path)
    sig = sign(path, keys["k"][0])
    sig.write_text(sig.read_text().replace(f"version={VERSION}", "version=9.9.10"))
    refusal(path, keys["k"][1], "the global signature does not verify")


def test_minisigns_own_trusted_comment_accepted(tmp_path, keys):
    """Plain `minisign -Sm` (its default trusted comment, `timestamp:... file:...`): verified, and said not to bind
    the bundle's name or version; a changed byte of the bundle is still refused."""
    path = make_bundle(tmp_path)
    minisign("-S", "-s", str(keys["k"][0]), "-m", path.name, cwd=tmp_path)
    assert "twoscale-bundle/" not in bundle.signature_path(path).read_text()
    assert bundle.status(path, public_key=keys["k"][1]) == "signed, verified, name and version not bound"
    data = bytearray(path.read_bytes())
    data[-1] ^= 1
    path.write_bytes(bytes(data))
    refusal(path, keys["k"][1], "does not verify")


def test_versions_lock_entry_checked(tmp_path, keys):
    """The comment's versions_lock_sha256 must be the SHA-256 of its version's line in versions.lock (as `twoscale
    verify` checks): another digest is refused as signed over other data, and a version the package does not
    record is refused, naming the version."""
    path = make_bundle(tmp_path)
    sign(path, keys["k"][0], text=comment(lock="ab" * 32))
    refusal(path, keys["k"][1], f"names versions.lock entry {'ab' * 32} for version {VERSION}, but {LOCK} is recorded")
    unrecorded = "9.9.9"
    other = make_bundle(tmp_path, name=f"twoscale-tables-{unrecorded}-{PRESET}.tar.gz")
    sign(other, keys["k"][0], text=comment(file=other.name, version=unrecorded))
    refusal(other, keys["k"][1], f"signed for version {unrecorded}, which this twoscale_tables' versions.lock does not record")


def test_package_versions_lock_is_the_repositorys():
    """The package's copy of versions.lock is manifests/versions.lock, byte for byte."""
    assert bundle.VERSIONS_LOCK.read_bytes() == (REPO / "manifests/versions.lock").read_bytes(), \
        "cp manifests/versions.lock pipeline/tables/python/twoscale_tables/"


def test_malformed_trusted_comment_refused(tmp_path, keys):
    path = make_bundle(tmp_path)
    sign(path, keys["k"][0], text=f"twoscale-bundle/1 file={NAME} version={VERSION} preset={PRESET}")  # no versions_lock_sha256
    refusal(path, keys["k"][1], "is not 'twoscale-bundle/1 file=")


@pytest.mark.parametrize("cut", ["lines", "base64"])
def test_truncated_signature_refused(tmp_path, keys, cut):
    path = make_bundle(tmp_path)
    sig = sign(path, keys["k"][0])
    lines = sig.read_text().splitlines()
    if cut == "lines":  # the trusted comment and global signature lost
        sig.write_text("\n".join(lines[:2]) + "\n")
        refusal(path, keys["k"][1], "not a minisign signature (four lines")
    else:  # the global signature's line cut short (still valid base64: 48 bytes)
        sig.write_text("\n".join(lines[:3] + [lines[3][:64]]) + "\n")
        refusal(path, keys["k"][1], "the global signature line: 48 bytes, expected 64")


def test_legacy_algorithm_refused(tmp_path, keys):
    path = make_bundle(tmp_path)
    sign(path, keys["k"][0], legacy=True)
    refusal(path, keys["k"][1], "signature algorithm 'Ed', expected 'ED'")


def test_bad_public_key_refused(tmp_path, keys):
    path = make_bundle(tmp_path)
    sign(path, keys["k"][0])
    raw = base64.b64decode(keys["k"][1].read_text().splitlines()[1])
    for key, needle in ((base64.b64encode(raw[:-1]).decode(), "41 bytes, expected 42"),
                        (base64.b64encode(raw + b"\0").decode(), "43 bytes, expected 42"),
                        ("RW!!" + base64.b64encode(raw).decode()[4:], "not base64")):
        with pytest.raises(ValueError, match=needle):
            bundle.status(path, public_key=key)
    with pytest.raises(ValueError, match="cannot read the public key .*missing.pub"):
        bundle.status(path, public_key=str(tmp_path / "missing.pub"))


def test_key_without_signature_refused(tmp_path, keys):
    path = make_bundle(tmp_path)
    msg = refusal(path, keys["k"][1], "no signature")
    assert "but a public key was given" in msg


def test_bundle_json_differs_from_comment_refused(tmp_path, keys):
    info = {"format": "twoscale-bundle/1", "version": "9.9.8", "preset": PRESET, "tables": []}
    path = make_bundle(tmp_path, info=info)
    sign(path, keys["k"][0])
    refusal(path, keys["k"][1], f"bundle.json's version is '9.9.8', the signature's '{VERSION}'")
    path = make_bundle(tmp_path, info={**info, "version": VERSION})
    sign(path, keys["k"][0], text=comment(target="scene=scene-test"))
    refusal(path, keys["k"][1], "bundle.json's scene is missing, the signature's 'scene-test'")


def test_unsafe_entries_refused(tmp_path):
    top = NAME[: -len(".tar.gz")]
    link = tarfile.TarInfo(f"{top}/t.h5")
    link.type, link.linkname = tarfile.SYMTYPE, "/etc/passwd"
    for entries, extra, needle in (({"/abs/t.h5": b"x"}, (), "not a relative name"),
                                   ({f"{top}/../t.h5": b"x"}, (), "not a relative name"),
                                   ({}, (link,), "is a link or special file")):
        path = write_tar(tmp_path / NAME, entries, extra)
        refusal(path, None, needle)
        assert not (tmp_path / "t.h5").exists()


def test_every_bit_flip_of_a_signature_refused(tmp_path, keys):
    """Every single-bit flip of the signature file (the untrusted comment, CR/LF and base64's unused bits
    included) and of 200 random bits of the bundle is refused: no byte of either goes unchecked."""
    path = make_bundle(tmp_path)
    sign(path, keys["k"][0])
    sig_path = bundle.signature_path(path)
    good, data = sig_path.read_bytes(), path.read_bytes()
    assert bundle.status(path, keys["k"][1]) == "signed, verified"
    accepted = []
    for i in range(len(good)):
        for bit in range(8):
            flipped = bytearray(good)
            flipped[i] ^= 1 << bit
            sig_path.write_bytes(bytes(flipped))
            try:
                bundle.status(path, keys["k"][1])
                accepted.append((i, bit))
            except ValueError:
                pass
    sig_path.write_bytes(good)
    rng = __import__("random").Random(62)
    for _ in range(200):
        i, bit = rng.randrange(len(data)), rng.randrange(8)
        flipped = bytearray(data)
        flipped[i] ^= 1 << bit
        path.write_bytes(bytes(flipped))
        try:
            bundle.status(path, keys["k"][1])
            accepted.append(("bundle", i, bit))
        except ValueError:
            pass
    print(f"{8 * len(good)} flips of the signature and 200 of the bundle: {len(accepted)} accepted")
    assert not accepted, f"flips accepted: {accepted[:10]}"


@pytest.mark.parametrize("change", ["crlf", "no space", "padding bits"])
def test_signature_format_is_strict(tmp_path, keys, change):
    """The same bytes spelt otherwise: CRLF line ends, the untrusted comment's prefix without its space, and
    a base64 line's unused bits set; each is refused (as the Rust and JS readers refuse them)."""
    path = make_bundle(tmp_path)
    sign(path, keys["k"][0])
    sig_path = bundle.signature_path(path)
    text = sig_path.read_text()
    lines = text.splitlines()
    if change == "crlf":
        text = text.replace("\n", "\r\n")
    elif change == "no space":
        text = text.replace("untrusted comment: ", "untrusted comment:", 1)
    else:
        last = lines[3]  # 64 bytes: 88 characters ending "==", the last data character carries 4 unused bits
        c = last[-3]
        alphabet = "ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789+/"
        text = text.replace(last, last[:-3] + alphabet[alphabet.index(c) ^ 1] + "==")
        assert base64.b64decode(text.splitlines()[3]) == base64.b64decode(last), "the same bytes, spelt otherwise"
    sig_path.write_text(text, newline="")
    refusal(path, keys["k"][1], {"crlf": "CR line endings", "no space": "not a minisign signature",
                                 "padding bits": "not canonical base64"}[change])
