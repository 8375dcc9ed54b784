"""The clocks of the EMPS closed-loop simulation (a light module: the CLI's choices)."""

# The recorded stamps, or the benchmark's constant period.
CLOCKS = ("true", "benchmark")
