"""Lane keeping with highway-env and a camera lane-marking input (paper §5.6)."""
