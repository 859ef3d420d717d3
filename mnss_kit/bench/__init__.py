"""Bench stage: speed against accuracy for every shipped model and trained ladder config.

    records.py   one record per model x precision (and per baseline), its keys and their check
    pareto.py    the Pareto front of cost against quality
    latency.py   NPU-stage CPU latency, int8 and fp32 timed side by side in one run
    run.py       the bench run: quality on held-out frames, int8 through the bundle and emulator,
                 latency, device estimates; resumable JSON
    charts.py    the charts made from that JSON
"""
