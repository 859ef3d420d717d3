"""Stress stage: built-in scenario sequences for the cases where supersamplers fail (DESIGN.md section 6).

    scenarios.py  the scenarios (one sequence of ``mnss_kit/configs/data/stress.yaml`` each) and the cases not covered
    run.py        every method over every scenario: per-scenario metrics, recovery after cuts and pans
    verdict.py    best and worst method per scenario and metric, and the markdown table saying so
    charts.py     per-frame PSNR of every method, one PNG per scenario
"""
