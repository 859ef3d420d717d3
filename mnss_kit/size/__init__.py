"""Size stage: a ladder of model configs trained on a user's scene, and the smallest that is good enough.

``run`` (``run_size``, the entry function) trains (or reuses) and evaluates every rung on held-out sequences, ``select`` applies
the quality targets and the device budget, ``charts`` draws the ladder.  ``mnss-kit export
OUT/size.json`` takes the chosen checkpoint.
"""
