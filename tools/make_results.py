"""Regenerate the measured parts of ``docs/results.md``.

    python tools/make_results.py [--only protocol-env1,references,...] [--no-run]

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

DE_GRID = [(f, cr) for f in (0.1, 0.3, 0.5, 0.8) for cr in (0.1, 0.5, 0.9)]
REFERENCE_ROWS = "spsa,astar-los,ompl-rrtstar,ompl-informed-rrtstar,ompl-bitstar"

# part → (scenarios, bench options)
PARTS: dict[str, tuple[list[str], list[str]]] = {
    # the paper's protocol: 3 environments x 6 algorithms x 30 runs, M = 1000, G = 30, every
    # algorithm on the paper's fitness; the raw search result and the post-processed route
    # are separate rows; plus the grid A* + line-of-sight reference. One command per
    # environment, so that a finished environment is kept if a later one is stopped.
    **{
        f"protocol-env{k}": (
            [PAPER_ENVS[k - 1]],
            [
                "--algorithms",
                "spsa,ssa,pso,gwo,de,cso,astar-los",
                "--runs",
                "30",
                "--fitness-smoothing",
                "0",
            ],
        )
        for k in (1, 2, 3)
    },
    # OMPL's sampling-based optimal planners for SPSA's mean wall time on each scenario
    "references": (
        PAPER_ENVS,
        ["--algorithms", REFERENCE_ROWS, "--runs", "30", "--fitness-smoothing", "0"],
    ),
    # the OMPL planners with ten times SPSA's wall time (their collision checks are Python
    # callbacks: how much of the gap is that?)
    "references-long": (
        ["missions/paper-env1.yaml"],
        [
            "--algorithms",
            "ompl-rrtstar(time_s=36),ompl-informed-rrtstar(time_s=36),ompl-bitstar(time_s=36)",
            "--runs",
            "2",
        ],
    ),
    # the same evaluation budget for every algorithm: 10 000 fitness evaluations (a third of
    # G x M; about a quarter of what SPSA scores in the protocol's M = 1000 iterations)
    "budget": (
        PAPER_ENVS,
        [
            "--algorithms",
            "spsa,ssa,pso,gwo,de,cso",
            "--budget",
            "evaluations=10000",
            "--runs",
            "3",
            "--fitness-smoothing",
            "0",
        ],
    ),
    # DE's F x CR grid on environment 1 (G = 30, M = 1000, 3 runs each): the default's source
    "de-sensitivity": (
        ["missions/paper-env1.yaml"],
        [
            "--algorithms",
            ",".join(f"de(f={f}; cr={cr})" for f, cr in DE_GRID),
            "--runs",
            "3",
            "--fitness-smoothing",
            "0",
        ],
    ),
    # every baseline at its best published setting (where it differs from our default)
    "sensitivity": (
        PAPER_ENVS,
        [
            "--algorithms",
            "pso(w_start=0.729; w_end=0.729; c1=1.494; c2=1.494),"
            "pso(v_max_fraction=0.2),de(f=0.5; cr=0.9),"
            "gwo(a_start=2; a_end=0),"
            "cso(rooster_ratio=0.15; hen_ratio=0.7; mother_ratio=0.5)",
            "--runs",
            "3",
            "--fitness-smoothing",
            "0",
        ],
    ),
    # older parts (SPSA's own ablation, project defaults, the city map): not in the default run
    "defaults": (PAPER_ENVS, ["--runs", "10"]),
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
    "midtown": (["missions/midtown-manhattan.yaml"], ["--runs", "10", "--fitness-smoothing", "0"]),
}
#: what ``make_results.py`` runs without --only
PROTOCOL = ["protocol-env1", "protocol-env2", "protocol-env3"]
DEFAULT_PARTS = [
    "de-sensitivity",
    *PROTOCOL,
    "references",
    "sensitivity",
    "budget",
    "references-long",
]

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
    """The ``uavplan bench`` command of ``part`` (niced: the machine is shared)."""
    scenarios, options = PARTS[part]
    return [
        "nice",
        "-n",
        "10",
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
    stamp = out / "command.json"  # missing when the bench ran outside this script
    total = json.loads(stamp.read_text())["wall_time_s"] if stamp.exists() else cfg["wall_time_s"]
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


def _rows(*parts: str) -> list[dict[str, str]]:
    rows: list[dict[str, str]] = []
    for part in parts:
        path = ROOT / OUT / part / "summary.csv"
        if path.exists():
            with open(path) as fh:
                rows += list(csv.DictReader(fh))
    return rows


def ratios_block(parts: list[str] | None = None) -> str:
    """The paper's Table 2 next to ours: per environment and algorithm the paper's mean and
    std, our raw search result (the paper's protocol) and our post-processed route energy,
    and SPSA's mean as a fraction of each (ours raw / ours post-processed / paper)."""
    ours = {(r["scenario"], r["algorithm"]): r for r in _rows(*(parts or PROTOCOL))}
    algs = ["spsa", "ssa", "pso", "gwo", "de", "cso"]
    lines = [
        "Means (std) over all runs. *Raw*: the best fitness the search reached, the paper's "
        "protocol; *route*: E of the route after the shared post-processing chain; "
        "SPSA ÷: SPSA's mean over the algorithm's (paper / ours raw / ours route).",
        "",
        "| env | algorithm | paper | ours, raw | ours, route | SPSA ÷ (paper / raw / route) |",
        "|---|---|---:|---:|---:|---:|",
    ]

    def f(r: dict[str, str] | None, key: str) -> float:
        return float(r[f"{key}_mean"]) if r and r[f"{key}_mean"] else float("nan")

    for env in (1, 2, 3):
        scn = f"paper-env{env}"
        spsa = ours.get((scn, "spsa"))
        if spsa is None:
            lines.append(f"| {env} | (not measured) | | | | |")
            continue
        for a in algs:
            r = ours.get((scn, a))
            pm, ps = PAPER[env][a]
            cells = []
            for key in ("search", "route"):
                if r is None or not r[f"{key}_mean"]:
                    cells.append("—")
                else:
                    cells.append(f"{float(r[f'{key}_mean']):.0f} ({float(r[f'{key}_std']):.0f})")
            ratio = (
                f"{PAPER[env]['spsa'][0] / pm:.2f} / {f(spsa, 'search') / f(r, 'search'):.2f} / "
                f"{f(spsa, 'route') / f(r, 'route'):.2f}"
            )
            lines.append(
                f"| {env} | {a.upper()} | {pm:.0f} ({ps:.0f}) | {cells[0]} | {cells[1]} | {ratio} |"
            )
    return "\n".join(lines)


def de_grid_block(part: str = "de-sensitivity") -> str:
    """DE's mean raw search result per (F, CR) and how many runs improved on the initial
    population at all (the search's first convergence point vs its last)."""
    rows = {r["algorithm"]: r for r in _rows(part)}
    doc = json.loads((ROOT / OUT / part / "bench.json").read_text())
    curves: dict[str, list[float]] = next(iter(doc["mean_convergence"].values()), {})
    crs = sorted({cr for _, cr in DE_GRID})
    lines = [
        "Mean raw search fitness (mean post-processed route energy) on paper-env1; the last "
        "line of each cell: the mean search fitness after the first iteration → after the last.",
        "",
        "| F \\ CR | " + " | ".join(str(cr) for cr in crs) + " |",
        "|---|" + "---:|" * len(crs),
    ]
    for f in sorted({f for f, _ in DE_GRID}):
        cells = []
        for cr in crs:
            label = f"de(f={f}; cr={cr})"
            r = rows.get(label)
            c = curves.get(label) or [float("nan")]
            if r is None:
                cells.append("—")
                continue
            cells.append(
                f"{float(r['search_mean']):.0f} ({float(r['route_mean']):.0f})<br>"
                f"{c[0]:.0f} → {c[-1]:.0f}"
            )
        lines.append(f"| F = {f} | " + " | ".join(cells) + " |")
    return "\n".join(lines)


def worth_block(part: str) -> str:
    """Each variant's mean final energy relative to full SPSA, per environment."""
    with open(ROOT / OUT / part / "summary.csv") as fh:
        rows = list(csv.DictReader(fh))
    key = "route_mean" if "route_mean" in rows[0] else "mean"
    envs = list(dict.fromkeys(r["scenario"] for r in rows))
    full = {r["scenario"]: float(r[key]) for r in rows if r["algorithm"] == "spsa"}
    variants = [a for a in dict.fromkeys(r["algorithm"] for r in rows) if a != "spsa"]
    means = {(r["scenario"], r["algorithm"]): float(r[key]) for r in rows}
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
    ap.add_argument("--workers", type=int, default=1)
    ap.add_argument(
        "--only", default=",".join(DEFAULT_PARTS), help="parts to run (comma-separated)"
    )
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
        if part not in DEFAULT_PARTS and part not in parts:
            continue  # an older part: its block shows the command that produced it
        if (ROOT / OUT / part / "bench.json").exists() and f"BEGIN {part} -->" in text:
            text = replace_block(text, part, block(part, args.workers))
    if any((ROOT / OUT / p / "summary.csv").exists() for p in PROTOCOL):
        text = replace_block(text, "ratios", ratios_block())
    if (ROOT / OUT / "de-sensitivity" / "summary.csv").exists():
        text = replace_block(text, "de-grid", de_grid_block())
    atomic_write_text(DOC, text)
    print(f"updated {DOC.relative_to(ROOT)}", file=sys.stderr)


if __name__ == "__main__":
    main()
