"""Studies at the edge: mesh convergence of the free rail, convergence of the supported
track in its support discretisation, beam section constants, and the pass-by error study's
report. They use the core and may draw figures; nothing in the core imports them."""
