"""The semantic model (paper 001, DESIGN.md §3): configurations, satisfaction and the safety property,
the six actions and their preconditions, and their proof for every size (z3). Imports only the DSL."""
