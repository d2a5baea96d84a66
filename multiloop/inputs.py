"""One resolver for every command's input: a file or a catalogue name.

Every ``multiloop`` command and :func:`multiloop.load` accept, wherever they take a
file, (i) a ``.toml``/``.json`` mechanism file, (ii) a Pyslvs project ``.pyslvs`` (or a
bare Pyslvs expression in an ``.expr`` file: the readers of :data:`topo.formats.FORMATS`),
and (iii) the name of a bundled mechanism (``multiloop catalogue`` lists them), looked up
in the catalogue folders when no file of that name exists.

Examples
--------
>>> resolve("four_bar").name
'four_bar.toml'
>>> load_mechanism("four_bar").frame
'frame'
"""
from __future__ import annotations

from importlib import resources
from pathlib import Path

from multiloop.topo.errors import InputError, explain
from multiloop.topo.formats import FORMATS, loads_mechanism, read_mechanism
from multiloop.topo.io import MAX_INPUT_BYTES
from multiloop.topo.model import Mechanism

__all__ = ["resolve", "load_mechanism", "load_mechanism_or_engine", "load_upload", "upload_text",
           "check_upload_size", "MAX_UPLOAD"]

#: largest upload accepted (bytes): the cap of the command line's file readers
MAX_UPLOAD = MAX_INPUT_BYTES


def resolve(arg: str | Path, folders: tuple[str, ...] = ("mechanisms", "engines")) -> Path:
    """The file ``arg`` when it exists, else the bundled ``<folder>/<arg>.toml``.

    Raises
    ------
    InputError
        Neither a file nor a catalogue name (the message lists the catalogue names).
    """
    p = Path(arg)
    if p.exists():
        return p
    base = resources.files("multiloop.catalogue")
    known: list[str] = []
    for sub in folders:
        folder = base / sub
        if not folder.is_dir():
            continue
        cand = folder / f"{arg}.toml"
        if cand.is_file():
            return Path(str(cand))
        known += sorted(e.name[:-5] for e in folder.iterdir() if e.name.endswith(".toml"))
    raise InputError(explain(f"file '{arg}'", expected="an existing file or a catalogue name",
                             got="neither", hint="catalogue names: " + ", ".join(known)))


def load_mechanism(arg: str | Path) -> Mechanism:
    """A :class:`Mechanism` from a ``.toml``/``.json``/``.pyslvs`` file or a catalogue name."""
    p = resolve(arg)
    if p.suffix.lower() not in FORMATS:       # (the TOML/JSON reader names an unknown suffix)
        from multiloop.topo.io import load  # noqa: PLC0415
        return load(p)
    return read_mechanism(p)


def load_mechanism_or_engine(path: str | Path) -> Mechanism:
    """:func:`load_mechanism`, or an engine file (``[engine]`` table) built as a mechanism
    with its gas forces as 1° force tables against the crank angle."""
    from multiloop.topo.io import read_document  # noqa: PLC0415
    p = resolve(path)
    if p.suffix.lower() in (".toml", ".json") and p.exists():
        doc = read_document(p)
        if isinstance(doc, dict) and "engine" in doc:
            from multiloop.kin.engine import engine_from_dict, engine_mechanism  # noqa: PLC0415
            try:
                return engine_mechanism(engine_from_dict(doc), gas_loads=True)
            except InputError as exc:
                raise InputError(f"{p}: {exc}") from None
    return load_mechanism(p)


def _bytes(n: int) -> str:
    return f"{n >> 20} MiB" if n >= 1 << 20 and n % (1 << 20) == 0 else f"{n} bytes"


#: what an upload is, in the hint of its size refusal
MECHANISM_UPLOAD = "upload a mechanism file, not a data set"


def check_upload_size(name: str, size: int, max_bytes: int = MAX_UPLOAD, hint: str = MECHANISM_UPLOAD) -> None:
    """Refuse an upload ``name`` of ``size`` bytes larger than ``max_bytes`` (``hint``: what
    the upload should be).

    Raises
    ------
    InputError
        ``size`` exceeds ``max_bytes``.
    """
    if size > max_bytes:
        raise InputError(explain(f"file '{name}'", expected=f"at most {_bytes(max_bytes)}",
                                 got=f"{size} bytes", hint=hint))


def upload_text(name: str, data: bytes, max_bytes: int = MAX_UPLOAD, hint: str = MECHANISM_UPLOAD) -> str:
    """The UTF-8 text of an uploaded file ``name`` (no disk), at most ``max_bytes``.

    Raises
    ------
    InputError
        Too large, or not UTF-8 (the messages of the file readers).
    """
    check_upload_size(name, len(data), max_bytes, hint)
    try:
        return data.decode("utf-8-sig")
    except UnicodeDecodeError as exc:
        raise InputError(explain(f"file '{name}'", expected="UTF-8 text",
                                 got=f"undecodable bytes ({exc.reason})")) from None


def load_upload(name: str, data: bytes, max_bytes: int = MAX_UPLOAD) -> Mechanism:
    """A :class:`Mechanism` from the bytes of an uploaded ``.toml``/``.json``/``.pyslvs``
    file, read by the same parsers as :func:`load_mechanism` without touching the disk."""
    suffix = Path(name).suffix.lower()
    if suffix not in FORMATS:
        raise InputError(explain(f"file '{name}'", expected="a .toml, .json or .pyslvs file",
                                 got=f"suffix '{suffix or '(none)'}'"))
    return loads_mechanism(upload_text(name, data, max_bytes), name)
