"""Figures and statistics from arrays and tables, the paper's own numbers, and the tables of
``summary.md``; nothing here simulates."""
