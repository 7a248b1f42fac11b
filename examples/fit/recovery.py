"""`twoscale fit` on the six synthetic conductors, two plastics and a subsurface material of
runtimes/testing/synthetic.py (the layered ones with `--model auto`, which must pick their model), without and with
5 % noise:
the error against the noise-free target (by the numpy model, at every valid sample), the parameters recovered, the
time from the file to the written scene; and the cost of fitting a subsample against all samples. Then the files of
runtimes/testing/out_of_family.py, outside the model's family: the model `--model auto` chooses, and the relative and
log RMS and the render's SMAPE of the three two-scale models and of `--compare`'s three microfacet-over-Lambert ones; and the wall time of
`--model auto` on every noise-free file (the conductors' own run, beside their `--model conductor` one). Writes
docs/fit_recovery.md (a generated file: the figures churn from run to run of the machine, not of the code).

    .venv/bin/python -m examples.fit.recovery [--tables tables-out] [--out docs/fit_recovery.md] [--part PART]

--part recovery or out-of-family runs one part and replaces only its own sections of an existing --out (a section
runs from its `## ` heading to the next; the title paragraph and first table are the recovery part's, and the
`--model auto` table keeps the other part's rows); all (the default) runs both and writes the file anew.

Needs the default preset's general tables (`make tables`); the targets are cached in target/tmp/merl-cache (the
first run computes them by brute force: a few minutes)."""
import argparse
import os
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import merl  # runtimes/testing (`make pyenv` installs it), as out_of_family, synthetic and twoscale_c
import out_of_family
import synthetic
from twoscale_c import twoscale_binary

REPO = Path(__file__).resolve().parents[2]

# the sections' headings (the recovery part also owns the lines before the first)
PARAMS, SUBSAMPLE = "## Parameters recovered (without noise)", "## A subsample or all samples"
OUTSIDE, AUTO = "## Files outside the model's family", "## `--model auto` on every file"
# the `--model auto` table's kinds of file, one per part
RECOVERY_KIND, OUTSIDE_KIND = "recovery", "outside the family"
AUTO_TARGET = 30  # seconds
# `--compare`'s models, in the table's order
COMPARED = ("twoscale_conductor", "twoscale_plastic", "twoscale_subsurface", "ggx_lambert", "beckmann_lambert", "epd_lambert")


def built(tmp, result):
    """The fitted scene's material folder (a layered model's fitted BRDF is evaluated by the C BRDF over it)."""
    if result["material"]["model"] == "conductor":
        return None
    name = result["material"]["name"]
    subprocess.run([twoscale_binary(), "build", "--quiet", "--scene", str(tmp / f"{name}.toml"), "--out", str(tmp / "built")], check=True)
    return tmp / "built" / f"scene-{name}" / name


def recovery(args, tables, tmp):
    """The recovery part: {heading: lines} of its sections ("" the title paragraph and first table), and the
    `--model auto` table's rows of the noise-free materials."""
    rows, params, costs, auto = [], [], [], []
    for name in [*synthetic.MATERIALS, *synthetic.PLASTICS, *synthetic.SUBSURFACE]:
        start = time.perf_counter()
        clean = synthetic.target(name, args.cache)
        print(f"{name}: target in {time.perf_counter() - start:.0f} s", file=sys.stderr)
        model = "conductor" if name in synthetic.MATERIALS else "auto"
        for noise in (0.0, 0.05):
            path = tmp / f"{name}.binary"
            merl.write(path, clean, noise=noise, seed=7)
            result, wall = synthetic.fit(path, args.tables, tmp, "--model", model)
            err = synthetic.relative_rms(synthetic.fitted_rho(result, tables, built(tmp, result), tmp / "c-cache"), clean)
            rows.append((name, model, result["model"], noise, err, result["error"]["relative_rms"], result["seconds"], wall))
            print(f"{name} noise {noise}: {err:.4f} against the target, {wall:.1f} s", file=sys.stderr)
            if noise == 0.0:
                params.append((name, synthetic.recovered(name, result)))
                if model == "conductor":  # the file as an unknown one is fitted: all three models
                    result, wall = synthetic.fit(path, args.tables, tmp, "--model", "auto")
                    print(f"{name} --model auto: {result['model']}, {wall:.1f} s", file=sys.stderr)
                auto.append(auto_row(name, RECOVERY_KIND, result["model"], wall))
        if name in ("narrow", "plain"):
            merl.write(path, clean)
            for samples in ("10000", "30000", "100000", "all"):
                result, wall = synthetic.fit(path, args.tables, tmp, "--model", "conductor", "--samples", samples)
                err = synthetic.relative_rms(synthetic.fitted_rho(result, tables), clean)
                costs.append((name, samples, result["error"]["fit_samples"], err, wall))
    threads = os.cpu_count()
    head = ["# `twoscale fit` on synthetic materials (generated by examples/fit/recovery.py)", "",
            f"Each material written as a MERL file by runtimes/testing/merl.py from the brute-force reference, fitted by "
            f"`twoscale fit` (default options, {threads} cores), and the fitted BRDF times cos theta_i compared with the "
            f"noise-free target at every valid sample by the numpy model (relative RMS = sqrt(sum (f - t)^2 / sum t^2)). "
            f"Targets: <= 2 % without noise, <= 5 % with 5 % multiplicative noise; <= 60 s per material.", "",
            "| material | --model -> chosen | noise | vs target | fit's own figure (vs its file) | fit's seconds | wall seconds |",
            "|---|---|---|---|---|---|---|"]
    head += [f"| {n} | {m} -> {c} | {x:.0%} | {e:.4f} | {o:.4f} | {s:.1f} | {w:.1f} |" for n, m, c, x, e, o, s, w in rows]
    recovered = [PARAMS, ""]
    for name, rec in params:
        recovered += [f"**{name}**: " + ", ".join(f"{k} {t:g} -> {g:.4g}" for k, t, g in rec), ""]
    subsample = [SUBSAMPLE, "", "| material | --samples | fitted samples | vs target | wall seconds |", "|---|---|---|---|---|"]
    subsample += [f"| {n} | {s} | {k} | {e:.4f} | {w:.1f} |" for n, s, k, e, w in costs]
    return {"": head, PARAMS: recovered[:-1], SUBSAMPLE: subsample}, auto


def out_of_family_runs(args, tmp):
    """[(file, --model auto's JSON and wall seconds, --compare's JSON and wall seconds)] of every out_of_family file."""
    runs = []
    for name in out_of_family.MATERIALS:
        path = out_of_family.write(name, tmp)
        auto, auto_wall = synthetic.fit(path, args.tables, tmp, "--model", "auto")
        compare, compare_wall = synthetic.fit(path, args.tables, tmp, "--compare")
        print(f"{name}: auto {auto['model']} {auto_wall:.1f} s, --compare {compare_wall:.1f} s", file=sys.stderr)
        runs.append((name, auto, auto_wall, compare, compare_wall))
    return runs


def out_of_family_section(runs):
    """The out-of-family part: {heading: lines} of its section, and the `--model auto` table's rows of its files."""
    lines = [OUTSIDE, "",
             "The files of runtimes/testing/out_of_family.py (a GGX, Beckmann or EPD coat with the exact Fresnel factor of a"
             " conductor or of ior 1.5 over a Lambertian base or a constant), each fitted by `--model auto` (the chosen "
             "model, the parameters it leaves at a bound) and by `--compare`: the three two-scale models and three "
             "microfacet coats over a Lambertian base (conductor Fresnel per channel, height-correlated Smith G2, kd / pi "
             "per channel), on the same samples with the same loss. Each cell: relative RMS (log RMS) over every valid "
             "sample, then the render's SMAPE (docs/fit.md \"The render\"), the smallest SMAPE in bold. Every file is a "
             "member of one comparison model, which should come near 0 on it: a `*_conductor_lambert` file of its coat's, a "
             "dielectric one of ggx_lambert or beckmann_lambert with k = 0 (a conductor's Fresnel factor is then the "
             "dielectric's), ggx_conductor_constant of ggx_lambert with kd = 0.01 pi.", "",
             "| file | chosen | " + " | ".join(m.removeprefix("twoscale_") for m in COMPARED) + " | auto wall s | --compare wall s | at a bound |",
             "|---" * (len(COMPARED) + 5) + "|"]
    auto_rows, counts, seconds = [], {}, {}
    for name, auto, auto_wall, compare, compare_wall in runs:
        models = {m["model"]: m for m in compare["comparison"]}
        best = min(m["render_smape"] for m in models.values())
        cells = []
        for key in COMPARED:
            m = models[key]
            cell = f"{m['relative_rms']:.3g} ({m['log_rms']:.2g}), {m['render_smape']:.2g}"
            cells.append(f"**{cell}**" if m["render_smape"] == best else cell)
            counts.setdefault(key, set()).add(m["parameters"])
            seconds.setdefault(key, []).append(m["seconds"])
        chosen = auto["model"]
        if compare["model"].removeprefix("twoscale_") != chosen:
            chosen += f" (--compare: {compare['model']})"
        bounds = ", ".join(a["name"] for a in auto["at_bounds"])
        lines.append(f"| {name} | {chosen} | " + " | ".join(cells) + f" | {auto_wall:.1f} | {compare_wall:.1f} | {bounds} |")
        auto_rows.append(auto_row(name, OUTSIDE_KIND, auto["model"], auto_wall))
    lines += ["", "Each model's fitted parameters and own fit time within `--compare`, over the files: " + "; ".join(
        f"{key.removeprefix('twoscale_')} {span(counts[key], '{:d}')} parameters, {span(seconds[key], '{:.1f}')} s" for key in COMPARED) + "."]
    return {OUTSIDE: lines}, auto_rows


def span(values, fmt):
    """'a' or 'a-b': the range of values."""
    lo, hi = fmt.format(min(values)), fmt.format(max(values))
    return lo if lo == hi else f"{lo}-{hi}"


def auto_row(name, kind, chosen, wall):
    return f"| {name} | {kind} | {chosen} | {wall:.1f} | {'yes' if wall <= AUTO_TARGET else '**no**'} |"


def auto_section(rows, kept):
    """The `--model auto` table: its rows of this run by kind, and the rows of the other kinds kept from `kept` (the
    section's lines in the existing file, or [])."""
    old = {}
    for line in kept:
        cells = [c.strip() for c in line.strip().strip("|").split("|")]
        if line.startswith("| ") and len(cells) > 1 and cells[1] in (RECOVERY_KIND, OUTSIDE_KIND):
            old.setdefault(cells[1], []).append(line)
    merged = {**old, **rows}
    return [AUTO, "",
            f"Wall seconds of `twoscale fit FILE --model auto` (default options, {os.cpu_count()} cores), from the file to "
            f"the written scene, on every noise-free file above. Target: <= {AUTO_TARGET} s per file.", "",
            f"| file | kind | chosen | wall seconds | <= {AUTO_TARGET} s |", "|---|---|---|---|---|",
            *(line for kind in (RECOVERY_KIND, OUTSIDE_KIND) for line in merged.get(kind, []))]


def sections(text):
    """{heading: lines} of a generated file, in order ("" the lines before the first `## `), trailing blank lines dropped."""
    out, key = {"": []}, ""
    for line in text.splitlines():
        if line.startswith("## "):
            key = line
            out[key] = []
        out[key].append(line)
    return {k: "\n".join(v).rstrip("\n").splitlines() for k, v in out.items()}


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--tables", type=Path, default=REPO / "tables-out", help="directory holding default/")
    ap.add_argument("--out", type=Path, default=REPO / "docs/fit_recovery.md")
    ap.add_argument("--cache", type=Path, default=REPO / "target/tmp/merl-cache")
    ap.add_argument("--part", choices=("all", "recovery", "out-of-family"), default="all",
                    help="run this part only and replace its sections in --out, keeping the others (default: all, a new file)")
    args = ap.parse_args()
    args.cache.mkdir(parents=True, exist_ok=True)
    tables = args.tables / "default"
    new, auto = {}, {}
    with tempfile.TemporaryDirectory() as tmp:
        tmp = Path(tmp)
        if args.part in ("all", "recovery"):
            part, auto[RECOVERY_KIND] = recovery(args, tables, tmp)
            new.update(part)
        if args.part in ("all", "out-of-family"):
            part, auto[OUTSIDE_KIND] = out_of_family_section(out_of_family_runs(args, tmp))
            new.update(part)
    doc = sections(args.out.read_text()) if args.part != "all" and args.out.exists() else {}
    new[AUTO] = auto_section(auto, doc.get(AUTO, []))
    doc.update(new)  # in place where the file has the section, else appended
    args.out.write_text("\n\n".join("\n".join(lines) for lines in doc.values() if lines) + "\n")
    print(args.out)


if __name__ == "__main__":
    main()
