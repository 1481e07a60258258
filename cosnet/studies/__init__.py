"""Studies of a net: normal modes (§6) and their analytic references, error estimates, families of runs
(sweeps) and their stores."""
