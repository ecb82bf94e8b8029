"""One entry point for zone files: :func:`read_zone_file` picks the reader (OpenAir, or
ED-269 / ED-318 JSON) by the file's content. The readers import only
:mod:`uavplan.sources.zones`; this module imports them, so the package has no import cycle."""

from __future__ import annotations

from pathlib import Path

from uavplan.sources.zones import MAX_FILE_BYTES, Zone, ZoneFileError, decode_text


def read_zone_file(path: str | Path) -> tuple[Zone, ...]:
    """The zones of an OpenAir file (``.txt``, ``.openair``, any text that is not JSON) or an
    ED-269 / ED-318 JSON file (content starting with ``{``). Any problem raises
    :class:`ZoneFileError` naming the file and the line or feature."""
    p = Path(path)
    name = str(path)
    try:
        size = p.stat().st_size
        if not p.is_file():
            raise ZoneFileError("not a file", file=name)
        if size > MAX_FILE_BYTES:
            raise ZoneFileError(
                f"{size / 2**20:.0f} MiB, larger than the {MAX_FILE_BYTES // 2**20} MiB a zone "
                "file may be",
                file=name,
            )
        data = p.read_bytes()
    except FileNotFoundError:
        raise ZoneFileError("file not found", file=name) from None
    except OSError as err:
        raise ZoneFileError(f"cannot be read ({err.strerror or err})", file=name) from None
    text = decode_text(data, name)
    head = text.lstrip()[:1]
    if head in ("{", "["):
        from uavplan.sources.ed269 import parse_ed_json

        return parse_ed_json(text, name)
    from uavplan.sources.openair import parse_openair

    return parse_openair(text, name)
