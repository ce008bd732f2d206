"""PPMC-312 codecs: parallel blocks, ASCII frames, upload files and a chip emulator.

`upload` turns tables into the bytes the chip takes (and back), `ascii` the
serial frames, `formats` the upload file formats, `emulator` answers each block
as the chip would. Frame layouts live once in `frames`.
"""

# The package's public API is upload's codec, named here one by one.
from .upload import (
    bus_writes,
    decode_free_curve,
    decode_init,
    decode_move,
    decode_table_read,
    decode_upload,
    encode_free_curve,
    encode_init,
    encode_move,
    encode_table,
    encode_table_read_response,
)

__all__ = [
    "bus_writes",
    "decode_free_curve",
    "decode_init",
    "decode_move",
    "decode_table_read",
    "decode_upload",
    "encode_free_curve",
    "encode_init",
    "encode_move",
    "encode_table",
    "encode_table_read_response",
]
