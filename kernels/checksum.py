"""One pass over the state's bits: a hash (the instability watch's test for a state changed
from outside between run() calls) and the first non-finite value."""

import numpy as np
from numba import njit

from .compiler import CACHED, CACHED_INNER

FNV_OFFSET = np.uint64(0xCBF29CE484222325)
FNV_PRIME = np.uint64(0x100000001B3)
EXPONENT = np.uint64(0x7FF0000000000000)   # all exponent bits set: inf or NaN


@njit(**CACHED_INNER)
def mix(h, w):
    """Return h after taking in the word w: an FNV-1a step (xor, multiply), whose multiply
    carries differences only upwards, then a shift that carries them down."""
    h = (h ^ np.uint64(w)) * FNV_PRIME
    return h ^ (h >> np.uint64(29))


@njit(**CACHED)
def scan_words(words, h):
    """Return (a hash of words (n,) uint64 continued from h: ``mix`` on four interleaved
    lanes, so that four multiplies are in flight; the index of the first word that is a
    non-finite float64, or -1). A zlib CRC-32 of a 10^5-element net's state took 10 ms,
    one FNV-1a lane 1.7 ms."""
    n = words.shape[0]
    h0, h1, h2, h3 = h, h ^ np.uint64(1), h ^ np.uint64(2), h ^ np.uint64(3)
    odd = 0
    for i in range(0, n - 3, 4):
        w0, w1, w2, w3 = words[i], words[i + 1], words[i + 2], words[i + 3]
        h0 = mix(h0, w0)
        h1 = mix(h1, w1)
        h2 = mix(h2, w2)
        h3 = mix(h3, w3)
        odd += 1 if (w0 & EXPONENT) == EXPONENT else 0
        odd += 1 if (w1 & EXPONENT) == EXPONENT else 0
        odd += 1 if (w2 & EXPONENT) == EXPONENT else 0
        odd += 1 if (w3 & EXPONENT) == EXPONENT else 0
    for i in range(n - n % 4, n):
        h0 = mix(h0, words[i])
        odd += 1 if (words[i] & EXPONENT) == EXPONENT else 0
    h = mix(mix(mix(mix(h0, h1), h2), h3), np.uint64(n))   # (a word: mix compiles once, for words)
    bad = -1
    if odd:
        for i in range(n):
            if (words[i] & EXPONENT) == EXPONENT:
                bad = i
                break
    return h, bad


def scan_state(state) -> tuple[int, str | None, int]:
    """(hash of every array of the state, the first array holding a non-finite value (its
    field name) or None, that value's row). The arrays must be contiguous float64, in C or
    Fortran order."""
    h, where, row = FNV_OFFSET, None, -1
    for name, a in zip(state._fields, state):
        h, bad = scan_words(np.ravel(a, order="K").view(np.uint64), h)
        h = np.uint64(h)
        if bad >= 0 and where is None:
            where, row = name, int(np.argwhere(~np.isfinite(a))[0, 0])
    return int(h), where, row


@njit(**CACHED)
def hash_segments(words, width, offsets, tag, h):
    """Update h (s,) uint64, the running hash of each of s segments, given words (n,) uint64
    (rows of ``width`` words), the CSR row offsets (s + 1,) of the segments, and a tag that
    tells this array from the others hashed into h. Offsets outside the words are clamped."""
    n = words.shape[0]
    for s in range(h.shape[0]):
        a = min(max(offsets[s] * width, 0), n)
        b = min(max(offsets[s + 1] * width, a), n)
        x = mix(h[s], np.uint64(tag))
        for i in range(a, b):
            x = mix(x, words[i])
        h[s] = mix(x, np.uint64(b - a))


GOLDEN = np.uint64(0x9E3779B97F4A7C15)   # odd


@njit(**CACHED)
def weigh_words(words, h):
    """Return h plus sum_i words[i] * (2 i + 1) GOLDEN (mod 2^64): a key of integer tables
    that any change of one entry changes (every weight is odd, so invertible mod 2^64), at the
    speed of a vectorised sum, several times cheaper than ``scan_words``' hash."""
    s = np.uint64(0)
    for i in range(words.shape[0]):
        s += words[i] * ((np.uint64(2 * i + 1)) * GOLDEN)
    return h + s
