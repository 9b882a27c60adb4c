"""The semantic model (paper 001, docs/design.md#the-semantic-model): configurations,
satisfaction and the safety property, the six actions and their preconditions, and their proof
for every size (z3). Imports only the DSL."""
