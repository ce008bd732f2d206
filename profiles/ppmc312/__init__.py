"""PPMC-312 codecs: parallel blocks, ASCII frames, upload files and a chip emulator.

`upload` turns tables into the bytes the chip takes (and back), `ascii` the
serial frames, `files` the upload file formats, `emulator` answers each block
as the chip would. Frame layouts live once in `frames`.
"""

# The package's public API is upload's; one list of names serves both.
from .upload import *  # noqa: F403
from .upload import __all__ as __all__
