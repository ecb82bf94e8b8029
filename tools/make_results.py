"""Regenerate the measured parts of ``docs/results.md``.

    python tools/make_results.py [--workers 2] [--only protocol,ablation,...]

Each part below is one ``uavplan bench`` command, run as a subprocess so that the command the
document shows is exactly what produced its numbers; its files go to ``docs/bench/<part>/``.
The blocks between ``<!-- BEGIN <name> -->`` and ``<!-- END <name> -->`` in the document are
then rewritten from those files; everything outside them (the analysis) is left as it is.
"""

from __future__ import annotations

import argparse
import csv
import json
import os
import platform
import re
import shlex
import subprocess
import sys
import time
from pathlib import Path

from uavplan.fileio import atomic_write_text

ROOT = Path(__file__).resolve().parent.parent
DOC = ROOT / "docs" / "results.md"
OUT = Path("docs") / "bench"
PAPER_ENVS = ["missions/paper-env1.yaml", "missions/paper-env2.yaml", "missions/paper-env3.yaml"]

# part → (scenarios, bench options)
PARTS: dict[str, tuple[list[str], list[str]]] = {
    # the paper's protocol: 3 environments x 6 algorithms x 30 runs, M = 1000, G = 30, every
    # algorithm on the paper's fitness (the baselines report their raw node path on it)
    "protocol": (PAPER_ENVS, ["--runs", "30", "--fitness-smoothing", "0"]),
    # the same with the project's defaults (what `uavplan plan` does): smoothed search fitness
    "defaults": (PAPER_ENVS, ["--runs", "10"]),
    # SPSA (project defaults) with the paper's contributions switched off one at a time, then
    # our additions one at a time, and the paper's SPSA with none of them
    "ablation": (
        PAPER_ENVS,
        [
            "--algorithms",
            "spsa,spsa(restarts=1),spsa(fitness_smoothing=0),spsa(select=best),"
            "spsa(refine=false),spsa(refine=false; tighten=false),"
            "spsa(fitness_smoothing=0; restarts=1; select=best; refine=false; tighten=false)",
            "--ablation",
            "--runs",
            "10",
        ],
    ),
    # the baselines' other published settings: is a result an artefact of one setting?
    "sensitivity": (
        PAPER_ENVS,
        [
            "--algorithms",
            "pso(v_max_fraction=0.2),de(cr=0.1),"
            "cso(rooster_ratio=0.15; hen_ratio=0.7; mother_ratio=0.5)",
            "--runs",
            "10",
            "--fitness-smoothing",
            "0",
        ],
    ),
    # the bundled city scenario, protocol settings
    "midtown": (["missions/midtown-manhattan.yaml"], ["--runs", "10", "--fitness-smoothing", "0"]),
}

# The paper's Table 2 (mean, std) per environment, for the ratio comparison.
PAPER = {
    1: {
        "cso": (6201.82, 413.09),
        "de": (4408.46, 243.01),
        "gwo": (3763.38, 83.02),
        "pso": (4676.34, 218.58),
        "ssa": (2686.43, 127.61),
        "spsa": (2008.42, 0.89),
    },
    2: {
        "cso": (6271.97, 465.75),
        "de": (4233.72, 244.00),
        "gwo": (3718.73, 177.03),
        "pso": (4710.89, 233.50),
        "ssa": (2882.40, 631.23),
        "spsa": (2043.68, 8.10),
    },
    3: {
        "cso": (6221.22, 381.40),
        "de": (4562.37, 752.85),
        "gwo": (3958.70, 578.59),
        "pso": (4683.83, 297.68),
        "ssa": (2784.55, 183.07),
        "spsa": (2004.95, 5.84),
    },
}


def command(part: str, workers: int) -> list[str]:
    scenarios, options = PARTS[part]
    return [
        "uavplan",
        "bench",
        *scenarios,
        *options,
        "--workers",
        str(workers),
        "--out",
        str(OUT / part),
        "-q",
    ]


def machine() -> str:
    cpu = platform.processor() or platform.machine()
    try:
        for line in Path("/proc/cpuinfo").read_text().splitlines():
            if line.startswith("model name"):
                cpu = line.split(":", 1)[1].strip()
                break
    except OSError:
        pass
    return f"{os.cpu_count()} CPUs ({cpu}), Python {platform.python_version()}"


def block(part: str, workers: int) -> str:
    out = ROOT / OUT / part
    doc = json.loads((out / "bench.json").read_text())
    cfg = doc["config"]
    runs = sum(row["runs"] for row in doc["summary"])
    total = json.loads((out / "command.json").read_text())["wall_time_s"]
    lines = [
        "```",
        shlex.join(command(part, workers)),
        "```",
        "",
        f"{runs} runs; the whole command took {total:.0f} s ({total / 60:.1f} min) of wall "
        f"time, the runs themselves {cfg['wall_time_s']:.0f} s, on {machine()}. Seeds "
        f"{cfg['seeds'][0]}–{cfg['seeds'][-1]} for every algorithm.",
        "",
        (out / "summary.md").read_text().strip(),
        "",
    ]
    for png in sorted(out.glob("convergence-*.png")):
        name = png.stem.removeprefix("convergence-")
        lines.append(f"![{part}: {name}]({png.relative_to(ROOT / 'docs').as_posix()})")
    return "\n".join(lines).strip()


def ratios_block(part: str = "protocol", suffix: str = "") -> str:
    """Our SPSA mean ÷ each algorithm's mean next to the paper's, and SPSA's spread; the
    algorithms are labelled ``<name><suffix>`` in ``part``."""
    with open(ROOT / OUT / part / "summary.csv") as fh:
        rows = list(csv.DictReader(fh))
    ours = {(r["scenario"], r["algorithm"].removesuffix(suffix)): r for r in rows}
    algs = ["ssa", "pso", "gwo", "de", "cso"]
    head = "| env | " + " | ".join(f"SPSA ÷ {a.upper()}" for a in algs) + " | SPSA std / mean |"
    lines = [
        "Each cell: ours (paper). Means of the final energy over all runs.",
        "",
        head,
        "|---|" + "---:|" * (len(algs) + 1),
    ]
    for env in (1, 2, 3):
        scn = f"paper-env{env}"
        spsa = ours.get((scn, "spsa"))
        if spsa is None:
            continue
        s_mean, s_std = float(spsa["mean"]), float(spsa["std"])
        p_mean, p_std = PAPER[env]["spsa"]
        cells = []
        for a in algs:
            r = ours.get((scn, a))
            mine = f"{s_mean / float(r['mean']):.2f}" if r else "—"
            cells.append(f"{mine} ({p_mean / PAPER[env][a][0]:.2f})")
        spread = f"{100 * s_std / s_mean:.2f} % ({100 * p_std / p_mean:.2f} %)"
        lines.append(f"| {env} | " + " | ".join(cells) + f" | {spread} |")
    return "\n".join(lines)


def worth_block(part: str) -> str:
    """Each variant's mean final energy relative to full SPSA, per environment."""
    with open(ROOT / OUT / part / "summary.csv") as fh:
        rows = list(csv.DictReader(fh))
    envs = list(dict.fromkeys(r["scenario"] for r in rows))
    full = {r["scenario"]: float(r["mean"]) for r in rows if r["algorithm"] == "spsa"}
    variants = [a for a in dict.fromkeys(r["algorithm"] for r in rows) if a != "spsa"]
    means = {(r["scenario"], r["algorithm"]): float(r["mean"]) for r in rows}
    lines = [
        "Mean final energy with the change, relative to full SPSA (positive: worse).",
        "",
        "| variant | " + " | ".join(envs) + " |",
        "|---|" + "---:|" * len(envs),
    ]
    for v in variants:
        cells = [f"{100 * (means[(e, v)] / full[e] - 1):+.1f} %" for e in envs]
        lines.append(f"| {v} | " + " | ".join(cells) + " |")
    return "\n".join(lines)


def replace_block(text: str, name: str, body: str) -> str:
    pattern = re.compile(
        rf"(<!-- BEGIN {re.escape(name)} -->\n).*?(<!-- END {re.escape(name)} -->)", re.S
    )
    if not pattern.search(text):
        raise SystemExit(f"{DOC}: no block {name!r}")
    return pattern.sub(lambda m: m.group(1) + body + "\n" + m.group(2), text)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--workers", type=int, default=2)
    ap.add_argument("--only", default=",".join(PARTS), help="parts to run (comma-separated)")
    ap.add_argument("--no-run", action="store_true", help="only refresh the document")
    args = ap.parse_args()
    parts = [p for p in args.only.split(",") if p]
    for part in parts:
        if part not in PARTS:
            raise SystemExit(f"unknown part {part!r} (known: {', '.join(PARTS)})")
        cmd = command(part, args.workers)
        if not args.no_run:
            print("$", shlex.join(cmd), flush=True)
            t0 = time.perf_counter()
            subprocess.run(cmd, cwd=ROOT, check=True)
            wall = {"command": shlex.join(cmd), "wall_time_s": round(time.perf_counter() - t0, 1)}
            atomic_write_text(ROOT / OUT / part / "command.json", json.dumps(wall) + "\n")
    text = DOC.read_text()
    for part in PARTS:
        if (ROOT / OUT / part / "bench.json").exists():
            text = replace_block(text, part, block(part, args.workers))
    if (ROOT / OUT / "protocol" / "summary.csv").exists():
        text = replace_block(text, "ratios", ratios_block())
    if (ROOT / OUT / "defaults" / "summary.csv").exists():
        text = replace_block(text, "ratios-defaults", ratios_block("defaults"))
    if (ROOT / OUT / "ablation" / "summary.csv").exists():
        text = replace_block(text, "ablation-worth", worth_block("ablation"))
    atomic_write_text(DOC, text)
    print(f"updated {DOC.relative_to(ROOT)}", file=sys.stderr)


if __name__ == "__main__":
    main()
