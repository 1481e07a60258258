"""The built-in effects, one module per family: each declares its keys, its record and its kernels
(cosnet.kernels) in one place."""
