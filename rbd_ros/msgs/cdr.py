# Copyright 2026 The rbd_ros authors
#
# Licensed under the Apache License, Version 2.0 (the "License");
# you may not use this file except in compliance with the License.
# You may obtain a copy of the License at
#
#     http://www.apache.org/licenses/LICENSE-2.0
#
# Unless required by applicable law or agreed to in writing, software
# distributed under the License is distributed on an "AS IS" BASIS,
# WITHOUT WARRANTIES OR CONDITIONS OF ANY KIND, either express or implied.
# See the License for the specific language governing permissions and
# limitations under the License.

"""
CDR (XCDR1, little endian) by ``struct``: the formats every output message is packed with.

A format starts with the 4-byte encapsulation header; alignment is counted after it, as rmw
does; padding bytes are zeros.
"""

import struct


def layout(*fields):
    """
    Return a ``struct`` format for CDR fields (after the encapsulation header).

    :param fields: ``'i'``/``'I'`` (4 bytes, 4-aligned), ``'d'`` (8 bytes, 8-aligned),
        ``bytes`` (a constant string: its uint32 length and its bytes with the NUL are packed
        from the arguments) or an int ``n`` (n zero bytes).
    """
    fmt, offset = ['<4s'], 0
    for field in fields:
        if isinstance(field, bytes):
            field = ('I', len(field))
        if isinstance(field, int):
            fmt.append(f'{field}x')
            offset += field
            continue
        code, size = (field, 0) if isinstance(field, str) else field
        align = 8 if code == 'd' else 4
        pad = -offset % align
        fmt.append(f'{pad}x{code}' if pad else code)
        offset += pad + 4 + (4 if code == 'd' else 0)
        if size:
            fmt.append(f'{size}s')
            offset += size
    return struct.Struct(''.join(fmt))


def cdr_string(text):
    """Return ``text`` as a CDR string's bytes: UTF-8 and its NUL (the length is packed apart)."""
    return text.encode('utf-8') + b'\x00'
