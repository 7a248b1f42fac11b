"""twoscale.js' signed exports (docs/file_contract.md "Signatures"): loadMaterial and loadTables with { publicKey }
verify SHA256SUMS.minisig (minisign's legacy Ed, by SubtleCrypto's Ed25519) before any binary is fetched. Exports
signed by Debian's minisign 0.11; every case in one page load (tests/harness.html, its `loads` jobs):

  loads    chi1's export signed with -l loads with its key (the .pub text or its base64 line) and evalPoints gives
           what the unsigned load gives; the general export too;
  refused  with one line naming SHA256SUMS.minisig or the key: another key pair's key, a prehashed (ED) signature,
           a changed trusted comment, a trusted comment not twoscale-export/1 or naming another material, a truncated
           signature, CRLF line ends, the untrusted comment's prefix without its space, base64 with unused bits set, a
           descriptor that is not JSON (its digest, not its parse, refuses it), none at all, a
           changed binary with the descriptor and SHA256SUMS rewritten to match (not re-signed: it loads without a
           key), a malformed key, an unknown option, a browser without Ed25519.
"""
import base64
import hashlib
import json
import shutil
import subprocess
import time

import numpy as np
import pytest
from browser import Server, export_webgl, run_page
from checks import random_pair
from twoscale_c import REPO, minisign, twoscale_binary

COMMENT = "twoscale-export/1 version=0.13.0 material=chi1"
N_POINTS = 64
SIG = "SHA256SUMS.minisig"
# case -> (the key: "a" (the signer's), "b" (another pair's) or a string; options beside publicKey; the message's parts)
REFUSED = {
    "wrong_key": ("b", {}, [f"{SIG}: signed by key ", "not by the public key given"]),
    "prehashed": ("a", {}, [f"{SIG}: algorithm ED ", "no BLAKE2b"]),
    "comment": ("a", {}, [f"{SIG}: the global signature does not verify"]),
    "foreign_comment": ("a", {}, [f"{SIG}: trusted comment \"other/1 ", "twoscale-export/1"]),
    "truncated": ("a", {}, [f"{SIG}: not a minisign signature ("]),
    "crlf": ("a", {}, [f"{SIG}: not a minisign signature (CR line endings"]),
    "no_space": ("a", {}, [f"{SIG}: not a minisign signature (line 1 is not its untrusted comment"]),
    "padding_bits": ("a", {}, [f"{SIG}: not a minisign signature (line 4 is not base64"]),
    "other_material": ("a", {}, [f"{SIG}: signed for \"twoscale-export/1 version=0.13.0 material=chi2\", not this export"]),
    "unsigned": ("a", {}, [f"{SIG}: HTTP 404"]),
    "tampered": ("a", {}, [f"{SIG}: the signature does not verify: SHA256SUMS"]),
    "bad_descriptor": ("a", {}, ["material.json: SHA-256 mismatch (SHA256SUMS has "]),
    "key_base64": ("RWQ!" + "A" * 52, {}, ["publicKey: not a minisign public key"]),
    "key_length": (None, {}, ["publicKey: not a minisign public key"]),
    "unknown_option": ("a", {"key": "x"}, ["loadMaterial: unknown option key"]),
    "no_ed25519": ("a", {}, [f"{SIG}: cannot verify: this browser's SubtleCrypto has no Ed25519"]),
}


def key_pair(folder):
    """An unencrypted minisign key pair in folder: (secret key path, the .pub file's text)."""
    folder.mkdir()
    minisign("-G", "-W", "-p", folder / "k.pub", "-s", folder / "k.key", "-f")
    return folder / "k.key", (folder / "k.pub").read_text()


def signed(src, out, key, legacy=True, comment=COMMENT):
    """A copy of the export src in out, its SHA256SUMS signed (legacy: Ed, else ED) with this trusted comment."""
    shutil.copytree(src, out)
    minisign("-S", *(["-l"] if legacy else []), "-s", key, "-m", out / "SHA256SUMS", "-t", comment)
    return out


def export_general(tables, out):
    """`twoscale export --format webgl --preset default` of the default preset's tables into out."""
    res = subprocess.run([twoscale_binary(), "export", "--quiet", "--format", "webgl", "--preset", "default", "--tables",
                          str(tables.parent), "--out", str(out)], capture_output=True, text=True)
    assert res.returncode == 0, res.stderr
    return out


def tamper(out):
    """A byte of epd_g1.bin flipped and its digest rewritten in material.json, then material.json's and epd_g1.bin's
    in SHA256SUMS: every checksum agrees, only the signature can tell."""
    f = out / "epd_g1.bin"
    b = bytearray(f.read_bytes())
    b[len(b) // 2] ^= 0x40
    f.write_bytes(bytes(b))
    desc = json.loads((out / "material.json").read_text())
    entry = next(e for e in desc["tables"] if e["file"] == f.name)
    entry["sha256"] = hashlib.sha256(b).hexdigest()
    (out / "material.json").write_text(json.dumps(desc, indent=2))
    lines = (out / "SHA256SUMS").read_text().splitlines()
    new = {name: hashlib.sha256((out / name).read_bytes()).hexdigest() for name in (f.name, "material.json")}
    (out / "SHA256SUMS").write_text("".join(f"{new.get(line[66:], line[:64])}  {line[66:]}\n" for line in lines))


@pytest.fixture(scope="module")
def signature_run(materials, tables, tmp_path_factory):
    """Every case in one harness page load: (results, the refused cases' expected message parts)."""
    data = tmp_path_factory.mktemp("webgl-signature")
    key_a, pub_a = key_pair(data / "a")
    _, pub_b = key_pair(data / "b")
    line_a = pub_a.splitlines()[1]
    unsigned = export_webgl(materials / "chi1", data / "unsigned")
    good = signed(unsigned, data / "good", key_a)
    rng = np.random.default_rng(7)
    x = np.array([[*wi, *wo, rng.uniform(0.4, 0.7), 0, 0] for wi, wo in (random_pair(rng, 0.2) for _ in range(N_POINTS))])
    x.astype(np.float32).tofile(data / "points.bin")

    folders = {"prehashed": signed(unsigned, data / "prehashed", key_a, legacy=False),
               "foreign_comment": signed(unsigned, data / "foreign_comment", key_a, comment="other/1 version=0.13.0 material=chi1"),
               "other_material": signed(unsigned, data / "other_material", key_a, comment=COMMENT.replace("chi1", "chi2")),
               "unsigned": unsigned}
    for case in ("comment", "truncated", "tampered", "crlf", "no_space", "padding_bits", "bad_descriptor"):
        folders[case] = shutil.copytree(good, data / case)
    (folders["bad_descriptor"] / "material.json").write_text("{")  # checked against the signed sums before parsing
    # the same bytes spelt otherwise: each must be refused (no character of a signature goes unchecked)
    text = (good / SIG).read_text()
    (folders["crlf"] / SIG).write_bytes(text.replace("\n", "\r\n").encode())
    (folders["no_space"] / SIG).write_text(text.replace("untrusted comment: ", "untrusted comment:", 1))
    last = text.splitlines()[3]  # 64 bytes: the character before "==" carries 4 unused bits
    alphabet = "ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789+/"
    respelt = last[:-3] + alphabet[alphabet.index(last[-3]) ^ 1] + "=="
    assert base64.b64decode(respelt) == base64.b64decode(last)
    (folders["padding_bits"] / SIG).write_text(text.replace(last, respelt))
    sig = folders["comment"] / SIG
    sig.write_text(sig.read_text().replace("material=chi1", "material=chi2"))
    sig = folders["truncated"] / SIG
    sig.write_bytes(sig.read_bytes()[:-40])
    tamper(folders["tampered"])
    general = export_general(tables, data / "general")
    signed_general = signed(general, data / "general-signed", key_a, comment="twoscale-export/1 version=0.13.0 preset=default")
    shutil.rmtree(general)

    def url(folder, file="material.json"):
        return f"/data/{folder.relative_to(data)}/{file}"

    loads = [{"id": "good", "url": url(good), "opts": {"publicKey": pub_a}, "points": "/data/points.bin"},
             {"id": "good_line", "url": url(good), "opts": {"publicKey": line_a}},
             {"id": "unsigned_plain", "url": url(unsigned), "points": "/data/points.bin"},
             {"id": "tampered_plain", "url": url(folders["tampered"])},
             {"id": "general", "url": url(signed_general, "tables.json"), "opts": {"publicKey": pub_a}, "general": True},
             {"id": "general_wrong_key", "url": url(signed_general, "tables.json"), "opts": {"publicKey": pub_b}, "general": True}]
    short = base64.b64encode(base64.b64decode(line_a)[:41]).decode()  # 41 bytes: valid base64, not a key
    for case, (key, opts, _) in REFUSED.items():
        key = {"a": pub_a, "b": pub_b, None: short}.get(key, key)
        loads.append({"id": case, "url": url(folders.get(case, good)), "opts": {"publicKey": key, **opts},
                      **({"noEd25519": True} if case == "no_ed25519" else {})})
    (data / "case.json").write_text(json.dumps({"loads": loads}))
    with Server({"/runtime/": REPO / "runtimes/webgl", "/data/": data}) as srv:
        t = time.time()
        page = run_page(srv.url("/runtime/tests/harness.html?case=/data/case.json"), budget_ms=60000, timeout=300)
        seconds = time.time() - t
    status = page.text("status")
    assert status == "done", f"harness page: {status!r}; console: {page.console[-20:]}"
    print(f"harness page: {seconds:.1f} s ({len(loads)} loads)")
    return json.loads(page.text("result"))


def test_webgl_signature_loads(signature_run):
    """The right key loads the signed export, as the .pub file's text or its base64 line, and evalPoints on it gives
    the unsigned load's values."""
    r = signature_run
    for job in ("good", "good_line", "unsigned_plain"):
        assert "rejected" not in r[job] and "error" not in r[job], f"{job}: {r[job]}"
    rho = [np.frombuffer(base64.b64decode(r[j]["rho"]), np.float32) for j in ("good", "unsigned_plain")]
    assert len(rho[0]) == N_POINTS and np.all(np.isfinite(rho[0])) and rho[0].max() > 0, rho[0]
    assert np.array_equal(rho[0], rho[1]), "evalPoints differs between the signed and the unsigned load"
    print(f"loaded with the key: {r['good']['tables']} tables; evalPoints at {N_POINTS} points as unsigned (max rho {rho[0].max():.4g})")


def test_webgl_signature_general(signature_run):
    """loadTables verifies the general export's signature the same way: its key loads it, another is refused."""
    r = signature_run
    assert r["general"].get("tables") == 8, f"loadTables with the key: {r['general']}"
    msg = r["general_wrong_key"].get("rejected")
    assert msg and msg.startswith(f"{SIG}: signed by key ") and "\n" not in msg, f"loadTables with another key: {r['general_wrong_key']}"
    print(f"general, another key: {msg}")


@pytest.mark.parametrize("case", REFUSED)
def test_webgl_signature_refused(signature_run, case):
    r = signature_run
    msg, parts = r[case].get("rejected"), REFUSED[case][2]
    assert msg, f"{case}: not refused: {r[case]}"
    print(f"{case}: {msg}")
    assert all(p in msg for p in parts) and "\n" not in msg, f"{case}: {msg!r}, expected {parts}"
    if case == "tampered":  # the checksums agree: without the key it loads
        assert "rejected" not in r["tampered_plain"] and "error" not in r["tampered_plain"], r["tampered_plain"]
