"""The format records: one `Format` per file format (render, parse, sniff, and
`render_chunks` for streams), one `FormatTable` per device (detection by content, the
extension breaking ties; aliases), what a parse gives (`Parsed`) and what a render is
told (`RenderOptions`, `Provenance`)."""

from __future__ import annotations

from collections.abc import Callable, Iterable, Iterator, Mapping, Sequence
from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import Any, Generic, TypeVar

from ..errors import DecodeError, FormatError, echo
from .crc import Integrity

T = TypeVar("T")

@dataclass(frozen=True)
class Provenance:
    """Where a file came from, for the comment a C header (and text files) carry."""

    command: str | None = None            # the command line that wrote it
    lines: tuple[str, ...] = ()           # device-specific: motor, clock, stages, totals

    @property
    def tool(self) -> str:
        return f"stepramp {tool_version()}"


@dataclass(frozen=True)
class RenderOptions:
    name: str | None = None               # C: prefix of the include guard and every symbol
    base_address: int = 0                 # Intel HEX: address of the first byte
    provenance: Provenance = field(default_factory=Provenance)
    # device fields a format writes ahead of the items: the JSON document's other keys
    # (e.g. an MC-200 stream's period_us), a settings file's summary lines
    header: Mapping[str, Any] = field(default_factory=dict)
    # items a chunk-wise render will be given, when known ahead (a C header can then
    # declare its array's size before the rows); None: unknown
    count: int | None = None


@dataclass(frozen=True)
class Parsed(Generic[T]):
    items: Sequence[T]
    format: str
    integrity: Integrity
    detail: str = ""                      # what was verified, or why nothing was


@dataclass(frozen=True)
class Format(Generic[T]):
    name: str
    description: str
    extensions: tuple[str, ...]
    render: Callable[[Sequence[T], RenderOptions], bytes]
    parse: Callable[[bytes], Parsed[T]]
    sniff: Callable[[bytes], bool]         # does this content look like the format?
    binary: bool = False
    # payload chunks → file chunks, for formats that stream (memory: one chunk)
    render_chunks: ChunkRender | None = None


ChunkRender = Callable[[Iterable[bytes], RenderOptions], Iterator[bytes]]


def chunked(render_chunks: ChunkRender, payload: Callable[[Sequence[T]], bytes]
            ) -> Callable[[Sequence[T], RenderOptions], bytes]:
    """The whole-list `render` of a streaming format: its `render_chunks` of the one
    chunk `payload(items)` (one renderer, so a streamed file equals a whole one)."""
    def render(items: Sequence[T], options: RenderOptions) -> bytes:
        data = payload(items)
        if options.count is None:
            options = replace(options, count=len(items))
        return b"".join(render_chunks([data], options))

    return render


class FormatTable(Generic[T]):
    """A device's formats, in detection order, with aliases (old names kept working)."""

    def __init__(self, device: str, formats: Sequence[Format[T]],
                 aliases: dict[str, str] | None = None) -> None:
        self.device = device
        self.formats = {f.name: f for f in formats}
        self.aliases = dict(aliases or {})

    @property
    def names(self) -> tuple[str, ...]:
        """Every accepted `--format` value, aliases included."""
        return (*self.formats, *self.aliases)

    def get(self, name: str) -> Format[T]:
        key = self.aliases.get(name, name)
        if key not in self.formats:
            raise FormatError(f"format: {echo(name)} is not one of {', '.join(self.names)}")
        return self.formats[key]

    def for_path(self, path: str | Path | None) -> Format[T] | None:
        """The format a file name's extension names, if it names one."""
        if path is None:
            return None
        suffix = Path(str(path)).suffix.lower()
        for f in self.formats.values():
            if suffix in f.extensions:
                return f
        return None

    def detect(self, data: bytes, path: str | Path | None = None) -> Format[T]:
        """The format of `data`: by content; the extension breaks a tie."""
        matches = [f for f in self.formats.values() if f.sniff(data)]
        if not matches:
            # "an" before a letter read with a vowel sound: A-Link, MC-200 ("em")
            article = "an" if self.device[:1] in "AEFHILMNORSX" else "a"
            raise DecodeError(f"not {article} {self.device} file in any known format "
                              f"({', '.join(self.formats)})")
        by_name = self.for_path(path)
        return by_name if by_name in matches else matches[0]

    def render(self, items: Sequence[T], fmt: str,
               options: RenderOptions | None = None) -> bytes:
        return self.get(fmt).render(items, options or RenderOptions())

    def render_chunks(self, chunks: Iterable[bytes], fmt: str,
                      options: RenderOptions | None = None) -> Iterator[bytes]:
        """The file in format `fmt`, chunk by chunk, from the payload's chunks."""
        chosen = self.get(fmt)
        if chosen.render_chunks is None:
            raise FormatError(f"format: {chosen.name} cannot be written chunk by chunk")
        return chosen.render_chunks(chunks, options or RenderOptions())

    def parse(self, data: bytes, path: str | Path | None = None,
              fmt: str | None = None) -> Parsed[T]:
        if not isinstance(data, bytes | bytearray | memoryview):
            raise FormatError(f"parse needs bytes, got {type(data).__name__}")
        raw = bytes(data)
        if raw.startswith(b"\xef\xbb\xbf"):  # a UTF-8 byte-order mark from a text editor
            raw = raw[3:]
        if not raw.strip():
            raise DecodeError("empty file")
        chosen = self.get(fmt) if fmt is not None else self.detect(raw, path)
        return chosen.parse(raw)


def tool_version() -> str:
    from importlib.metadata import PackageNotFoundError, version

    try:
        return version("stepramp")
    except PackageNotFoundError:  # pragma: no cover - running from a bare checkout
        return "unknown (not installed: pip install -e .)"
