"""The base layer (DESIGN.md section 2): errors, runtime and precision, typed configuration, atomic
outputs. Every package may import it; it imports none of them."""
