"""Every diagnostic code reconf reports, written once: its stable rule name (the SARIF rule
id's name) and what it means. The README's table is generated from here, and a test fails
on a code that is reported but not listed, or listed but never reported.

    python -m reconf_dsl.codes --write    # rewrite the README's table
    python -m reconf_dsl.codes --check    # fail if it is out of date
"""
from __future__ import annotations

import argparse
import sys
from dataclasses import dataclass
from pathlib import Path

__all__ = ["Code", "CODES", "BY_CODE", "readme_table"]


@dataclass(frozen=True)
class Code:
    code: str
    name: str
    meaning: str


CODES: tuple[Code, ...] = tuple(Code(*row) for row in (
    ("RC000", "internal-error", "internal error (please report it)"),
    ("RC001", "syntax-error", "syntax error (unexpected token or end of file)"),
    ("RC002", "unexpected-character", "unexpected character"),
    ("RC003", "unterminated-string", "unterminated string"),
    ("RC004", "unterminated-comment", "unterminated block comment"),
    ("RC005", "not-utf8", "file is not UTF-8"),
    ("RC006", "empty-file", "empty file"),
    ("RC007", "file-not-found", "file not found, unreadable or unwritable, or a directory with no `.arch` file"),
    ("RC008", "include-not-found", "included file not found"),
    ("RC009", "include-cycle", "include cycle"),
    ("RC010", "file-too-large", "file over 64 MiB (standard input too: no more is read)"),
    ("RC011", "tool-missing", "an external program or library is missing: Graphviz `dot`, or z3 for "
                              "`verify-meta-model --unbounded`"),
    ("RC012", "picture-too-large", "`graph`/`graph-plan --format svg` of a picture over 400 nodes (components, "
                                   "connectors, environment inputs) refused: Graphviz `dot` takes minutes beyond "
                                   "that; write `--format dot` and render it yourself, or pass `--force`"),
    ("RC013", "output-format-mismatch", "`graph`, `graph-plan`, `ftm expand`: the extension of `-o` contradicts "
                                        "`--format` (`x.svg` with `--format dot`, `x.arch` with DOT in it), or names "
                                        "an image format reconf does not draw (`.png`, `.pdf`); without `--format`, "
                                        "the extension says the format"),
    ("RC014", "not-a-regular-file", "not a regular file: a device, FIFO or socket is refused, unread"),
    ("RC015", "input-too-large", "the files of one system over 128 MiB together (includes included)"),
    ("RC016", "include-outside-tree", "an include that leads (after symlinks and `..`) outside the directory tree "
                                      "of the file named on the command line, or of the current directory for `-`; "
                                      "refused unread unless `reconf --allow-includes-outside` or "
                                      "`RECONF_ALLOW_INCLUDES_OUTSIDE=1`"),
    ("RC017", "includes-too-deep", "includes nested more than 32 deep"),
    ("RC018", "nesting-too-deep", "more than 64 nested parentheses (an FTM expression)"),
    ("RC101", "unknown-name", "unknown message type or host"),
    ("RC102", "duplicate-name", "duplicate name"),
    ("RC103", "unknown-component", "unknown component in an attachment"),
    ("RC104", "unknown-port", "unknown port in an attachment"),
    ("RC105", "wrong-side", "an input on the publisher side of `->`, or an output on the subscriber side"),
    ("RC106", "connector-type-mismatch", "port and connector carry different message types"),
    ("RC107", "unknown-functionality-port", "functionality names a port its component does not have"),
    ("RC108", "guarantee-not-an-output", "guarantee for a port that is not an output of the functionality"),
    ("RC109", "missing-mode", "functionality without a normal or a degraded mode"),
    ("RC110", "repeated-mode", "functionality with two normal or two degraded modes"),
    ("RC111", "degraded-assumes", "degraded mode assumes something"),
    ("RC112", "degraded-not-covered", "degraded guarantee not covered by the normal one"),
    ("RC113", "bad-rate", "rate zero, negative or out of range (a number of over 32 characters, or an exponent "
                          "beyond ±32)"),
    ("RC114", "unknown-unit", "unknown rate unit"),
    ("RC115", "system-declaration", "missing, repeated or conflicting `system` declaration"),
    ("RC116", "single-topic-publishers", "`single` topic with several publishers"),
    ("RC117", "service-servers", "service with several servers"),
    ("RC118", "unknown-replaced", "`replaces` names an unknown component"),
    ("RC119", "bad-criticality", "criticality not a whole number (or out of range, as for RC113)"),
    ("RC121", "guarantee-type-mismatch", "a guarantee of another message type than its output port carries"),
    ("RC122", "version-attached", "a replacement version attached to a connector"),
    ("RC123", "port-on-two-connectors", "a port attached to two connectors"),
    ("RC124", "unknown-ftm-term", "unknown FTM, fault or application characteristic"),
    ("RC125", "bad-resource", "bad resource (CPUs, bandwidth)"),
    ("RC126", "nothing-asked", "`nothing` as an assumption or connector guarantee"),
    ("RC127", "output-named-assume", "an output named `assume`"),
    ("RC128", "node-unknown-name", "a `node` block names a port or functionality its component does not have"),
    ("RC129", "node-port-name", "a port of a `node` component without its ROS name, with two, or sharing one with "
                                "another port"),
    ("RC130", "node-mode-effect", "a `node` block's mode line that cannot be: `deactivate` on a node not declared "
                                  "`lifecycle`, `deactivate` or `hold` in a normal mode, a deactivation that "
                                  "silences another functionality's outputs, two lines for one mode, two `node` "
                                  "blocks"),
    ("RC131", "node-parameter", "a parameter a `node` block sets: a value ROS 2 cannot hold (a number, a string, "
                                "`true` or `false`), set in one mode of a functionality and not in the other, set "
                                "twice, or by two functionalities"),
    ("RC132", "node-on-service", "a port of a `node` component on a `service` connector (its adapter relays "
                                 "topics)"),
    ("RC133", "bad-duration", "a `takes` line that cannot be: an action that is not one of the six, a time not "
                              "in s or ms, a negative one, or an action timed twice"),
    ("RC201", "assumption-not-satisfied", "an assumption does not hold (from `check`)"),
    ("RC300", "engines-disagree", "the Python engine and Alloy disagree (a bug in reconf; both verdicts are shown)"),
    ("RC301", "alloy-unavailable", "Java or the Alloy jar missing"),
    ("RC302", "alloy-rejected-module", "Alloy rejected a generated module"),
    ("RC303", "alloy-too-large", "warning: the system is too large for Alloy (atom capacity or heap); with "
                                 "`--engine both` the verdict is the Python engine's alone, and says so; an error "
                                 "(exit 2) when a plan cannot be verified in Alloy for that reason"),
    ("RC304", "plan-step-refused", "`plan verify`: a step's precondition does not hold in the configuration before "
                                   "it (the rule is named: `attach.single`, `detach.output`, …)"),
    ("RC305", "plan-step-effect", "`plan verify`: the configuration after a step is not that step's effect"),
    ("RC306", "plan-state-ill-formed", "`plan verify`: a configuration of the plan is not well formed (two "
                                       "publishers on a `single` topic, two servers of a service, an attachment of "
                                       "the wrong type or of an absent component)"),
    ("RC307", "plan-state-unsafe", "`plan verify`: a configuration of the plan is not valid (an assumption does not "
                                   "hold)"),
    ("RC308", "plan-document-invalid", "`plan verify`: the plan document is not JSON, or not of the shape of "
                                       "docs/executor.md (format 1 or 2)"),
    ("RC309", "plan-name-unknown", "`plan verify`: the plan names a component, port, connector or functionality the "
                                   "architecture does not declare"),
    ("RC310", "plan-batch-unsafe", "`plan verify`: a batch of steps the document runs together is unsafe in some "
                                   "order its steps can complete in (a state some order reaches is not valid or well "
                                   "formed, or a step is refused in it), or is not a run of steps on distinct "
                                   "components"),
    ("RC401", "ftm-ill-formed", "a fault-tolerance mechanism expression is not well formed"),
    ("RC402", "ftm-fault-not-covered", "the attached mechanism does not tolerate a declared fault"),
    ("RC403", "ftm-application-mismatch", "the mechanism needs an application characteristic the component lacks "
                                          "(LFR on a non-deterministic server, PBR without state access)"),
    ("RC404", "ftm-bandwidth", "the mechanism needs more bandwidth than is available"),
    ("RC405", "ftm-cpus", "the mechanism needs more CPUs than are available"),
    ("RC406", "ftm-placement", "a duplex mechanism's replicas are not on distinct hosts"),
    ("RC407", "ftm-nothing-to-protect", "a component with an FTM serves no service or topic to protect"),
    ("RC408", "ftm-none-to-expand", "`ftm expand` of a component with no FTM"),
    ("RC409", "ftm-name-taken", "expanding an FTM needs a component or connector name that is taken"),
    ("RC499", "ftm-engines-disagree", "`reconf ftm`: the Python engine and Alloy disagree on the valid "
                                      "compositions (a bug in reconf)"),
    ("RC501", "no-safe-plan", "`reconf gate`: no verified migration plan from the base to the head"),
    ("RC502", "disruption-over-policy", "`reconf gate`: the plan disrupts more than the policy's `max-disruption`"),
    ("RC503", "protected-functionality-degraded", "`reconf gate`: the plan degrades a functionality the policy "
                                                  "says must never be degraded"),
    ("RC504", "ftm-weakened", "`reconf gate`: a fault covered by an FTM in the base is no longer covered"),
    ("RC505", "invalid-policy", "`reconf gate`: bad policy (a value of the wrong type, an unknown key)"),
    ("RC506", "unreadable-revision", "`reconf gate`: an architecture cannot be read from the git revision"),
    ("RC507", "unsafe-architecture", "`reconf gate`: the new architecture is not safe as `check` judges it (an "
                                     "assumption or a fault-tolerance rule fails), so no migration to it is planned"),
    ("RC508", "policy-name-unknown", "`reconf gate`: a policy name (`never-degrade`, `keep-ftm`) names no component, "
                                     "functionality or FTM of the head or the base"),
    ("RC509", "unsafe-base", "`reconf gate`: the base is not safe, so no plan from it exists; an error by default "
                             "(the fix is not let through)"),
    ("RC510", "unsafe-base-allowed", "`reconf gate`: the base is not safe, with `--allow-unsafe-base` or "
                                     "`allow-unsafe-base = true`: a warning, the head passes alone, to be deployed "
                                     "by other means"),
    ("RC511", "report-not-written", "`reconf gate`: a `--report` file cannot be written"),
    ("RC512", "degraded-seconds-over-policy", "`reconf gate`: the plan is expected to keep what served degraded "
                                              "longer than the policy's `max-degraded-seconds`"),
    ("RC601", "discover-placeholder", "warning, `reconf discover`: a guess where only the graph is known (a node "
                                      "without `reconf.model`, a topic with no rate or no publisher), marked "
                                      "`// placeholder:` in the written `.arch`"),
    ("RC602", "ros-unavailable", "`reconf discover`, `reconf drift`: ROS 2 is not installed or did not start, or "
                                 "a snapshot file cannot be read: the live system cannot be read"),
    ("RC611", "drift-component-missing", "`reconf drift`: a deployed component has no node in the live system"),
    ("RC612", "drift-component-extra", "`reconf drift`: a node with topics or services that no deployed component "
                                       "of the model accounts for"),
    ("RC613", "drift-attachment", "`reconf drift`: a port attached elsewhere than the model attaches it, not "
                                  "attached, or attached to a connector the model does not have"),
    ("RC614", "drift-message-type", "`reconf drift`: a topic carries another message type than its connector's"),
    ("RC615", "drift-mode", "`reconf drift`: a functionality's mode live is not the deployed configuration's"),
    ("RC616", "drift-single-publishers", "`reconf drift`: several publishers on a `single` topic or a service"),
    ("RC617", "drift-lifecycle", "`reconf drift`: a component's node is not active (or does not answer)"),
    ("RC618", "drift-model", "`reconf drift`: a component's node runs another model than the architecture's "
                             "(its `reconf.model`: ports, message types, functionalities, modes' predicates)"),
    ("RC619", "drift-no-control-interface", "`reconf drift`: a component's node does not implement the control "
                                            "interface (a node not started through its adapter, or not a reconf "
                                            "node): its modes and attachments cannot be read"),
    ("RC621", "smh-not-yaml", "`reconf modes import`: the model file is not YAML"),
    ("RC622", "smh-not-a-model", "`reconf modes import`: YAML, but not an SMH model file of ROS 2 system_modes (a "
                                 "part without modes, a first mode other than `__DEFAULT__`, a node mode without "
                                 "`ros__parameters`, an unknown lifecycle state)"),
    ("RC623", "smh-placeholder", "warning, `reconf modes import`: SMH does not say it (ports, message types, rates, "
                                 "topics): a `// placeholder` comment in the architecture"),
    ("RC624", "smh-not-carried-over", "warning, `reconf modes import`: what the SMH file says that an architecture "
                                      "does not (system modes, rules, parameter values, lifecycle states other than "
                                      "active, a node name that is not a DSL name): kept as a comment, or renamed"),
    ("RC625", "smh-unsafe-default", "`reconf modes export`: the deployed configuration is not safe, so its "
                                    "`__DEFAULT__` mode would not be (exit 1); a warning with `--degrade-unsafe`"),
    ("RC631", "recover-left-alone", "warning, `reconf recover --live`: a node that is no component of the model and "
                                    "that no plan started (no creation mark): left alone"),
    ("RC632", "recover-unreadable", "`reconf recover --live`: a node of the model (or one a plan started) runs but "
                                    "does not answer, or runs a model that does not parse: no plan can start from "
                                    "a configuration not known (exit 2)"),
    ("RC633", "recover-other-definition", "warning, `reconf recover --live`: a node under a component's name runs "
                                          "another definition of it (an older version a killed plan left): it is "
                                          "that component as it runs, and the model's is created beside it as its "
                                          "new version"),
    ("RC701", "recording-unreadable", "`check --bag`: the recording cannot be read (missing, not a rosbag2 directory, "
                                      ".db3 or .mcap, or corrupt)"),
    ("RC702", "recording-rate-contradicted", "`check --bag`: a topic's observed rate (its worst sliding window) is "
                                             "under a rate the model states of it, beyond `--tolerance`"),
    ("RC703", "recording-type-contradicted", "`check --bag`: a modelled topic is recorded with another message type"),
    ("RC704", "recording-topic-absent", "warning, `check --bag`: a modelled topic (or an environment's stream) is not "
                                        "in the recording: not judged, not evidence either way"),
    ("RC705", "recording-too-short", "warning, `check --bag`: the recording is shorter than the window: no rate judged"),
    ("RC706", "recording-nothing-judged", "`check --bag`: the recording judged none of the model's promises (every "
                                          "one RC704 or RC705): not answered, exit 2"),
))
BY_CODE: dict[str, Code] = {c.code: c for c in CODES}

README = Path(__file__).resolve().parent.parent / "README.md"
BEGIN, END = "<!-- codes: generated by `python -m reconf_dsl.codes --write` -->", "<!-- codes: end -->"


def readme_table() -> str:
    rows = [f"| {c.code} | {c.meaning.replace('|', '/')} |" for c in CODES]
    return "\n".join([BEGIN, "| code | meaning |", "|---|---|", *rows, END])


def _rewritten(text: str) -> str:
    start, end = text.index(BEGIN), text.index(END) + len(END)
    return text[:start] + readme_table() + text[end:]


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(prog="python -m reconf_dsl.codes", description=__doc__.split("\n\n")[0])
    group = parser.add_mutually_exclusive_group(required=True)
    group.add_argument("--write", action="store_true", help="rewrite the README's table of codes")
    group.add_argument("--check", action="store_true", help="fail if the README's table is out of date")
    args = parser.parse_args(argv)
    text = README.read_text(encoding="utf-8")
    if args.check:
        if _rewritten(text) != text:
            print("README.md: the table of diagnostic codes is out of date: python -m reconf_dsl.codes --write",
                  file=sys.stderr)
            return 1
        return 0
    README.write_text(_rewritten(text), encoding="utf-8")
    print(f"wrote the table of {len(CODES)} codes in {README}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
