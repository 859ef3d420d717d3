"""Evaluation: the model against baselines on full sequences.

``run``            ``evaluate_model``, the entry function: a checkpoint (or none) and the baselines over a dataset
``loop.evaluate``  the loop (any ``{name: per-frame method}``), returns a summary dict
``baselines``      bicubic and TAAU with the model's per-frame interface
``methods``        the model and its no-history ablation as per-frame methods
``frames``         reading sequences into per-frame inputs (the one place that reads data)
``summary``        means, per-sequence breakdowns, frames to recover after a cut
``report``         CSV, JSON, terminal table; ``crops``: labelled PNG crops
``command``        ``mnss-kit eval``

Kept free of imports so ``mnss-kit --help`` stays fast.
"""
