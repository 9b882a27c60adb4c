"""The language server (`reconf lsp`) and the warm analyzer `reconf check` talks to."""
