"""Diagnostic codes as stable rule ids: a short name and description per code or range of codes."""
from __future__ import annotations

RULES: dict[str, tuple[str, str]] = {
    "RC000": ("internal-error", "reconf failed unexpectedly"),
    "RC011": ("tool-missing", "An external program reconf needs is not installed"),
    "RC012": ("picture-too-large", "A picture is too large for Graphviz to lay out in reasonable time"),
    "RC013": ("output-format-mismatch", "The output file's extension contradicts the format asked for"),
    "RC014": ("not-a-regular-file", "A device, FIFO or socket was named where an architecture file was expected"),
    "RC015": ("input-too-large", "The files of one system are larger together than reconf reads"),
    "RC016": ("include-outside-tree", "An include leads outside the directory tree of the file named"),
    "RC017": ("includes-too-deep", "Includes are nested deeper than reconf follows"),
    "RC018": ("nesting-too-deep", "Parentheses are nested deeper than reconf reads"),
    "RC201": ("assumption-not-satisfied", "An assumption of a functionality does not hold in the architecture"),
    "RC300": ("engines-disagree", "The Python engine and the Alloy Analyzer disagree"),
    "RC301": ("alloy-unavailable", "Java or the Alloy jar is missing"),
    "RC302": ("alloy-rejected-module", "The Alloy Analyzer rejected a generated module"),
    "RC303": ("alloy-too-large", "The system is too large for the Alloy Analyzer; the verdict is the Python engine's"),
    "RC401": ("ftm-ill-formed", "A fault-tolerance mechanism expression is not well formed"),
    "RC402": ("ftm-fault-not-covered", "The attached fault-tolerance mechanism does not tolerate a declared fault"),
    "RC403": ("ftm-application-mismatch", "The mechanism needs an application characteristic the component lacks"),
    "RC404": ("ftm-bandwidth", "The mechanism needs more bandwidth than is available"),
    "RC405": ("ftm-cpus", "The mechanism needs more CPUs than are available"),
    "RC406": ("ftm-placement", "A duplex mechanism's replicas are not on distinct hosts"),
    "RC501": ("no-safe-plan", "No verified migration plan from the base architecture to the new one"),
    "RC502": ("disruption-over-policy", "The migration plan disrupts more than the policy's max-disruption"),
    "RC503": ("protected-functionality-degraded", "The migration degrades a functionality the policy says must "
              "never be degraded"),
    "RC504": ("ftm-weakened", "A fault covered by a fault-tolerance mechanism in the base is no longer covered"),
    "RC505": ("invalid-policy", "The gate's policy cannot be read"),
    "RC506": ("unreadable-revision", "An architecture cannot be read from the git repository"),
    "RC507": ("unsafe-architecture", "The new architecture is not safe, so no migration to it is planned"),
    "RC508": ("policy-name-unknown", "A name in the gate's policy names nothing in the architectures"),
    "RC509": ("unsafe-base", "The base architecture is not safe, so no plan from it exists"),
    "RC510": ("unsafe-base-allowed", "The base is not safe; the safe head passes alone, to be deployed by other means"),
    "RC511": ("report-not-written", "A report file of the gate cannot be written"),
}

_RANGES: list[tuple[str, str, str]] = [
    ("RC0", "input", "The input cannot be read"),
    ("RC1", "architecture", "The architecture is not well formed"),
    ("RC2", "safety", "The architecture is not safe"),
    ("RC3", "verification", "Verification could not be completed"),
    ("RC4", "fault-tolerance", "A fault-tolerance mechanism does not fit the component"),
    ("RC5", "gate", "The change does not pass the gate"),
]


def rule(code: str) -> tuple[str, str]:
    """(name, description) of a code; unknown codes get the description of their range."""
    if code in RULES:
        return RULES[code]
    for prefix, name, text in _RANGES:
        if code.startswith(prefix):
            return (f"{name}-{code.lower()}", text)
    return (code.lower(), "reconf finding")
