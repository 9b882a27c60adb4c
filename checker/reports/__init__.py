"""Reports for people and machines: text with source snippets, JSON documents, SARIF, GitHub and JUnit
(`formats`), pictures, the plan document, progress lines."""
