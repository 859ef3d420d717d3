"""Training stage: recurrent windows, the MNSS loss, truncated BPTT, resumable and data-parallel.

Entry points: ``mnss-kit train CONFIG`` (``command.py``), ``python -m mnss_kit.train``
(the same, for ``torchrun``), and ``run.train(experiment, out_dir)``.
"""
