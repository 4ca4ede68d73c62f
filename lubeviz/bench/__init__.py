"""The figures of BENCHMARKS.md, one module per subject, all run by `lubeviz bench ...` (`cli.bench_cmd`).

- `film`: film solves, mesh study, smoothness in the supply flow;
- `rotor`: the rotor against ROSS, stability;
- `identify`: tables cold and warm, one identification, the paper's reproduction;
- `records`: rates over independent records (coverage, static position, large orbits, diagnosis, budget);
- `broken`: broken measurements diagnosed (`verification.broken` breaks the records);
- `read`: reading a large record (memory and time).
"""
