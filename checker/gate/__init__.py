"""The judgements users ask for: `check` of one architecture, and the CI gate of a change from a
deployed architecture to a proposed one, within a policy."""
