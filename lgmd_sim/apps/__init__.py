"""The applications built on the testbed: `lgmd-sim demo` (`demo`, with the closed-loop
episode in `avoid` and the defaults in `defaults`) and `lgmd-sim record` (`record`)."""
