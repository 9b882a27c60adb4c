"""What the tests share: generators of inputs (DSL documents, architectures, plans, gate
repositories, recordings) and the fixtures (`fixtures.py`, registered by tests/conftest.py).
The table of example architectures stays in tests/examples_table.py."""
