"""The GA, the chromosome layout, and the evaluators that connect them to a problem."""
