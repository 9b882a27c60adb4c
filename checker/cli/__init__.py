"""The `reconf` command line: one module per command, holding its click options and no domain logic;
`common` holds what they share (exit codes, `Failure`, options, output, atomic writes); `main` is
the group."""
