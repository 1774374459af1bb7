"""The GA and its executors (local, process pool, Ray), and learning while driving (§5.5)."""
