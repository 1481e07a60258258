"""A fast checksum of the state's bits (the instability watch's test for a state changed
from outside between run() calls)."""

import numpy as np
from numba import njit

FNV_OFFSET = np.uint64(0xCBF29CE484222325)
FNV_PRIME = np.uint64(0x100000001B3)


@njit(cache=True)
def checksum_words(words, h):
    """Return the FNV-1a hash, continued from h, of words (n,) uint64: one multiply per word
    (a zlib CRC-32 of the state of a 10^5-element net took 10 ms, this about 1)."""
    for i in range(words.shape[0]):
        h = (h ^ words[i]) * FNV_PRIME
    return h


def checksum(arrays) -> int:
    """Hash of the bits of every array (each contiguous in C or Fortran order, 8-byte items)."""
    h = FNV_OFFSET
    for a in arrays:
        h = np.uint64(checksum_words(np.ravel(a, order="K").view(np.uint64), h))
    return int(h)
