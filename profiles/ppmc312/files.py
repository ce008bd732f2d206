"""Upload files: kept for old imports; the formats live in `profiles.ppmc312.formats`."""

from ..formats import hex_line
from .formats import FORMATS, parse, parse_upload, render

__all__ = ["FORMATS", "hex_line", "parse", "parse_upload", "render"]
