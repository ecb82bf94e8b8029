"""The one YAML reader of the project: a scenario or map file's bytes → a plain document.

The file is read as bytes and must be UTF-8 (a UTF-8 byte-order mark is accepted, UTF-16/32
are refused by name); duplicate keys are refused; the document may hold at most
:data:`~uavplan.scenario.limits.MAX_YAML_NODES` values once aliases are expanded and nest at
most :data:`~uavplan.scenario.limits.MAX_YAML_DEPTH` deep. Every problem is one
:class:`~uavplan.errors.ScenarioError` naming the file.

:func:`read_yaml` tries the fast path first (:func:`load_fast`: long lists of one-line flow
items read by the C JSON parser) and falls back to the full loader (:func:`load_full`,
PyYAML's safe loader), whose results and messages the fast path must match
(tests/scenario/test_fast_yaml.py).
"""

from __future__ import annotations

import functools
import json
import re
from pathlib import Path
from typing import Any, NamedTuple

import yaml  # type: ignore[import-untyped]

from uavplan.config import short_repr
from uavplan.errors import ScenarioError
from uavplan.scenario.limits import MAX_FILE_BYTES, MAX_YAML_DEPTH, MAX_YAML_NODES

_BaseLoader: Any = getattr(yaml, "CSafeLoader", yaml.SafeLoader)


class Loader(_BaseLoader):  # type: ignore[misc,valid-type]
    """The safe loader (libyaml's when present) refusing duplicate keys."""

    def construct_mapping(self, node: Any, deep: bool = False) -> Any:
        if isinstance(node, yaml.MappingNode):
            seen: set[Any] = set()
            for key_node, _ in node.value:
                if key_node.tag == "tag:yaml.org,2002:merge":
                    continue
                key = self.construct_object(key_node, deep=False)
                try:
                    duplicate = key in seen
                    seen.add(key)
                except TypeError:
                    continue  # unhashable: the base class says so
                if duplicate:
                    mark = key_node.start_mark
                    raise _DuplicateKey(key, mark.line + 1, mark.column + 1)
        return super().construct_mapping(node, deep=deep)


Loader.add_constructor(yaml.resolver.BaseResolver.DEFAULT_MAPPING_TAG, Loader.construct_mapping)


class _DuplicateKey(Exception):
    def __init__(self, key: Any, line: int, column: int) -> None:
        self.key, self.line, self.column = key, line, column


def decode(data: bytes, file: str, what: str) -> str:
    """The file's text: UTF-8 (a leading byte-order mark is dropped); anything else is a
    clear error."""
    boms = (
        (b"\xff\xfe\x00\x00", "UTF-32"),
        (b"\x00\x00\xfe\xff", "UTF-32"),
        (b"\xff\xfe", "UTF-16"),
        (b"\xfe\xff", "UTF-16"),
    )
    for bom, name in boms:
        if data.startswith(bom):
            raise ScenarioError(f"the {what} file is {name} encoded; save it as UTF-8", file=file)
    if data.startswith(b"\xef\xbb\xbf"):
        data = data[3:]
    try:
        return data.decode("utf-8")
    except UnicodeDecodeError as err:
        line = data.count(b"\n", 0, err.start) + 1
        raise ScenarioError(
            f"the {what} file is not UTF-8 text (byte 0x{data[err.start]:02x} on line {line}); "
            "save it as UTF-8",
            file=file,
        ) from None


def read_yaml(path: Path, what: str) -> Any:
    file = str(path)
    try:
        with open(path, "rb") as handle:
            data = handle.read(MAX_FILE_BYTES + 1)
    except FileNotFoundError:
        raise ScenarioError(f"{what} file not found", file=file) from None
    except IsADirectoryError:
        raise ScenarioError(f"the {what} file is a directory", file=file) from None
    except OSError as err:
        raise ScenarioError(f"cannot read {what} file: {err.strerror or err}", file=file) from None
    if len(data) > MAX_FILE_BYTES:
        raise ScenarioError(
            f"the {what} file is larger than {MAX_FILE_BYTES // (1024 * 1024)} MiB", file=file
        )
    text = decode(data, file, what)
    fast = load_fast(text, file)
    if fast is not None:
        return fast
    return load_full(text, file, what)


def load_full(text: str, file: str, what: str) -> Any:
    """The document through PyYAML's safe loader (libyaml's parser when present), refusing
    duplicate keys, with the size limits checked: the reference every fast path must match."""
    try:
        data_ = yaml.load(text, Loader=Loader)
    except _DuplicateKey as err:
        raise ScenarioError(
            f"invalid YAML: line {err.line}, column {err.column}: duplicate key "
            f"{short_repr(err.key)}",
            file=file,
        ) from None
    except yaml.YAMLError as err:
        if _nesting_exceeds(text, MAX_YAML_DEPTH):  # the parser's own limit, in its words
            raise ScenarioError(
                f"invalid YAML: nested more than {MAX_YAML_DEPTH} levels deep", file=file
            ) from None
        mark = getattr(err, "problem_mark", None)
        where = f"line {mark.line + 1}, column {mark.column + 1}: " if mark else ""
        problem = getattr(err, "problem", None) or str(err).splitlines()[0]
        raise ScenarioError(f"invalid YAML: {where}{problem}", file=file) from None
    except RecursionError:
        raise ScenarioError(
            f"invalid YAML: nested more than {MAX_YAML_DEPTH} levels deep", file=file
        ) from None
    except (ValueError, OverflowError) as err:  # e.g. an integer of more than 4300 digits
        raise ScenarioError(f"invalid YAML: {short_repr(str(err))}", file=file) from None
    if data_ is None:
        raise ScenarioError(f"the {what} file is empty", file=file)
    check_size(data_, file)
    return data_


# The fast path. PyYAML builds Python objects in pure Python even over libyaml's parser
# (about 0.3 ms an obstacle: 20,000 obstacles took 7-17 s). Generated maps hold long lists
# of one-line flow items under a top-level key:
#
#     obstacles:
#       - {type: box, center: [420, 40], size: [160, 140], height: 180, yaw: 20}
#       - {type: cylinder, center: [850, -60.5], radius: 110, height: 220}  # a comment
#
# Such a list is read by the C JSON parser when every item is in a strict subset on which YAML
# 1.1 (safe loader) and JSON agree: lower-case words that resolve to strings (not yes/no/
# on/off/true/false/null), decimal numbers without exponent, leading zero or "+" (int without
# a dot, float with one), flow sequences of numbers or of such sequences, flow mappings of
# word keys. The list's lines are blanked and the rest of the document goes through the full
# loader, which must show the key at that line with an empty value, nothing else between it
# and the next top-level key. Any doubt (another shape, a duplicate key, an error anywhere,
# the size limits) means the whole file goes through the full loader, so the result and
# every error message are the full loader's (tests/scenario/test_fast_yaml.py checks equivalence).

_NUM = r"-?(?:0|[1-9][0-9]*)(?:\.[0-9]+)?"
_WORD = r"(?!(?:yes|no|true|false|on|off|null)(?![a-z0-9_]))[a-z_][a-z0-9_]*"
_SEQ1 = rf"\[ *{_NUM}(?: *, *{_NUM})* *\]"
_SEQ2 = rf"\[ *{_SEQ1}(?: *, *{_SEQ1})* *\]"
_PAIR = rf"{_WORD}: +(?:{_NUM}|{_WORD}|{_SEQ1}|{_SEQ2})"
_MAP = rf"\{{ *{_PAIR}(?: *, *{_PAIR})* *\}}"


class _FastPatterns(NamedTuple):
    item_line: re.Pattern[str]
    key_line: re.Pattern[str]
    skip_line: re.Pattern[str]
    #: splits a fast list at its words (kept at the odd places): joining with '"' quotes them
    json_word_split: re.Pattern[str]


@functools.cache
def fast_patterns() -> _FastPatterns:
    """Compiled on first use: a few milliseconds that a small scenario never needs."""
    return _FastPatterns(
        re.compile(rf"( *)- +({_MAP}|{_SEQ1}|{_SEQ2})(?: +#[^\n]*)? *"),
        re.compile(rf"({_WORD}): *(?: #[^\n]*)?"),
        re.compile(r" *(?:#[^\n]*)?"),
        re.compile(r"([a-z_][a-z0-9_]*)"),
    )


#: lists shorter than this stay with the full loader (nothing to gain)
FAST_MIN_ITEMS = 16


class _NotFast(Exception):
    pass


def _json_pairs(pairs: list[tuple[str, Any]]) -> dict[str, Any]:
    out = dict(pairs)
    if len(out) != len(pairs):
        raise _NotFast  # a duplicate key: the full loader says where
    return out


def _fast_blocks(lines: list[str]) -> list[tuple[int, int, str, list[str]]]:
    """(key line, end line, key, flow items) of every top-level ``key:`` whose value is a
    block list of fast items (blank and comment lines allowed between them) ending at the
    end of the file or at a line starting in column 0 with something else."""
    pat = fast_patterns()
    blocks = []
    n = len(lines)
    i = 0
    while i < n:
        line = lines[i]
        key = pat.key_line.fullmatch(line) if line[:1].islower() or line[:1] == "_" else None
        if key is None:
            i += 1
            continue
        j, indent, items = i + 1, None, []
        while j < n:
            item = pat.item_line.fullmatch(lines[j])
            if item is not None:
                if indent is None:
                    indent = item.group(1)
                elif item.group(1) != indent:
                    break
                items.append(item.group(2))
            elif pat.skip_line.fullmatch(lines[j]) is None:
                break
            j += 1
        ends = j == n or lines[j][:1] not in ("", " ", "\t", "-", "#")
        if len(items) >= FAST_MIN_ITEMS and ends:
            blocks.append((i, j, key.group(1), items))
        i = max(j, i + 1)
    return blocks


def load_fast(text: str, file: str) -> dict[str, Any] | None:
    """The document with its long flow-item lists read as JSON; None when the file does not
    qualify or anything is in doubt (the caller then uses the full loader)."""
    if len(text) > MAX_YAML_NODES or any(c in text for c in "\r\x85\u2028\u2029"):
        return None  # the node-count bound below needs the length; other line breaks
    if text.count("- ") < FAST_MIN_ITEMS:
        return None  # every fast item line has one: too few to make a fast list
    lines = text.split("\n")
    blocks = _fast_blocks(lines)
    if not blocks:
        return None
    try:
        values = {}
        fast_nodes = 0
        for first, end, key, items in blocks:
            for k in range(first + 1, end):
                lines[k] = ""
            flow = ",".join(items)
            # nodes in the list: collections + (elements and pairs) + keys
            collections = flow.count("[") + flow.count("{")
            fast_nodes += collections + flow.count(",") + 1 + flow.count(":")
            js = "[" + '"'.join(fast_patterns().json_word_split.split(flow)) + "]"
            values[first] = (key, json.loads(js, object_pairs_hook=_json_pairs))
        loader = Loader("\n".join(lines))
        try:
            root = loader.get_single_node()
            if not isinstance(root, yaml.MappingNode):
                return None
            pairs = root.value
            lines_of_keys = [k.start_mark.line for k, _ in pairs]
            for first, end, key, _ in blocks:
                at = lines_of_keys.index(first) if first in lines_of_keys else -1
                if at < 0:
                    return None
                knode, vnode = pairs[at]
                if (
                    not isinstance(knode, yaml.ScalarNode)
                    or knode.value != key
                    or knode.start_mark.column != 0
                    or knode.style not in (None, "")
                    or not isinstance(vnode, yaml.ScalarNode)
                    or vnode.tag != "tag:yaml.org,2002:null"
                    or vnode.value != ""
                    or (at + 1 < len(pairs) and lines_of_keys[at + 1] < end)
                ):
                    return None
            doc = loader.construct_document(root)
        finally:
            loader.dispose()
        if not isinstance(doc, dict) or check_size(doc, file) + fast_nodes > MAX_YAML_NODES:
            return None
        for key, value in values.values():
            if key not in doc or doc[key] is not None:
                return None
            doc[key] = value
        return doc
    except Exception:  # any doubt: the full loader decides and reports
        return None


def _nesting_exceeds(text: str, limit: int) -> bool:
    """Whether the document opens more than `limit` nested collections. Asked only once the
    parser has refused the text: libyaml has a nesting limit of its own (1,000 in PyYAML
    6.0.4's wheels), reported in its own words, which are not ours to repeat or to match.
    PyYAML's pure-Python parser has no such limit and streams its events, so it stops here as
    soon as the limit is passed."""
    depth = 0
    try:
        for event in yaml.parse(text, Loader=yaml.SafeLoader):
            if isinstance(event, yaml.CollectionStartEvent):
                depth += 1
                if depth > limit:
                    return True
            elif isinstance(event, yaml.CollectionEndEvent):
                depth -= 1
    except yaml.YAMLError:
        pass
    return False


def check_size(doc: Any, file: str) -> int:
    """Refuse documents nested deeper than MAX_YAML_DEPTH, with more than MAX_YAML_NODES
    values once aliases are expanded (a "billion laughs" file), or that contain themselves.
    Returns the number of values."""
    sizes: dict[int, int] = {}
    active: set[int] = set()

    def size(value: Any, depth: int) -> int:
        if not isinstance(value, list | dict):
            return 1
        ident = id(value)
        known = sizes.get(ident)
        if known is not None:
            return known
        if ident in active:
            raise ScenarioError("invalid YAML: an alias refers to its own anchor", file=file)
        if depth > MAX_YAML_DEPTH:
            raise ScenarioError(
                f"invalid YAML: nested more than {MAX_YAML_DEPTH} levels deep", file=file
            )
        active.add(ident)
        items = value if isinstance(value, list) else [*value.keys(), *value.values()]
        total = 1
        for item in items:
            total += size(item, depth + 1)
            if total > MAX_YAML_NODES:
                raise ScenarioError(
                    f"the file holds more than {MAX_YAML_NODES:,} values once its aliases are "
                    "expanded",
                    file=file,
                )
        active.discard(ident)
        sizes[ident] = total
        return total

    return size(doc, 0)
