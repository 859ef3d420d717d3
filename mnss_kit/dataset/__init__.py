"""Dataset format (what engine exporters write), checks, and the PyTorch loader."""
