"""What every layer uses: errors, checked files and atomic writes, progress messages, the
cache folder, Ctrl-C and SIGTERM, the registry of names bound to code, the traffic keys'
ledger, the geometry of bodies and segments, the controller network, and the digests that
say which code made a result."""
