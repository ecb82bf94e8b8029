"""The sizes docs/architecture.md quotes, from the code: each layer's files and lines, and
every module over the limit.

    python tools/arch_sizes.py [--limit 800]

The layers are tests/architecture/test_layering.py's (the table the import rules are
checked against), so a module in no layer fails there, not here. Lines are physical lines,
blank lines and docstrings included (``wc -l``). Prints Markdown.
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT / "tests" / "architecture"))

from test_layering import LAYERS, PKG, layer_of  # noqa: E402  (the one table of the layers)


def sizes() -> dict[str, list[tuple[str, int]]]:
    """Layer → its modules (path relative to the package, lines), largest first."""
    out: dict[str, list[tuple[str, int]]] = {layer: [] for layer in LAYERS}
    for path in sorted(PKG.rglob("*.py")):
        if "__pycache__" in path.parts:
            continue
        layer = layer_of(path, PKG)
        if layer is None:
            continue
        with path.open("rb") as f:
            lines = sum(1 for _ in f)
        out[layer].append((path.relative_to(PKG).as_posix(), lines))
    for modules in out.values():
        modules.sort(key=lambda m: (-m[1], m[0]))
    return out


def c_sizes() -> list[tuple[str, int]]:
    """The C kernels' files (``_csrc/``), largest first."""
    found = []
    for path in sorted((PKG / "_csrc").glob("*.[ch]")):
        with path.open("rb") as f:
            found.append((path.name, sum(1 for _ in f)))
    return sorted(found, key=lambda m: (-m[1], m[0]))


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--limit", type=int, default=800, help="modules over this many lines")
    args = parser.parse_args()
    table = sizes()
    print("| layer | files | lines | largest module (lines) |")
    print("|---|---:|---:|---|")
    total_files = total_lines = 0
    for layer, modules in table.items():
        lines = sum(n for _, n in modules)
        total_files += len(modules)
        total_lines += lines
        largest = f"`{modules[0][0]}` ({modules[0][1]:,})" if modules else ""
        print(f"| {layer} | {len(modules)} | {lines:,} | {largest} |")
    print(f"| **package** | {total_files} | {total_lines:,} | |")
    print()
    over = sorted(
        ((name, n) for modules in table.values() for name, n in modules if n > args.limit),
        key=lambda m: -m[1],
    )
    print(f"Python modules over {args.limit:,} lines: {len(over)}")
    for name, n in over:
        print(f"- `{name}`: {n:,}")
    c = c_sizes()
    if c:
        print()
        print(
            f"C files: {len(c)}, {sum(n for _, n in c):,} lines; the largest `_csrc/{c[0][0]}`"
            f" ({c[0][1]:,})"
        )


if __name__ == "__main__":
    main()
