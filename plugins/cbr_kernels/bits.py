"""Bit counting for the compiled kernels that keep sets as 64-bit words."""

from __future__ import annotations

import numpy as np

from cbr_kernels import njit

_M1 = np.uint64(0x5555555555555555)
_M2 = np.uint64(0x3333333333333333)
_M4 = np.uint64(0x0F0F0F0F0F0F0F0F)
_LOW = np.uint64(0x7F)
_ONE = np.uint64(1)
_TWO = np.uint64(2)
_FOUR = np.uint64(4)
_EIGHT = np.uint64(8)
_SIXTEEN = np.uint64(16)
_THIRTY_TWO = np.uint64(32)


@njit(inline="always")
def popcount(x: np.uint64) -> int:
    """The set bits of ``x``: summed in pairs, nibbles, then bytes by shifts and adds alone,
    which run on SIMD lanes (a 64-bit multiply does not)."""
    x = x - ((x >> _ONE) & _M1)
    x = (x & _M2) + ((x >> _TWO) & _M2)
    x = (x + (x >> _FOUR)) & _M4
    x = x + (x >> _EIGHT)
    x = x + (x >> _SIXTEEN)
    x = x + (x >> _THIRTY_TWO)
    return np.int64(x & _LOW)
