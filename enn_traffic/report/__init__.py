"""CSV tables and matplotlib figures."""
