"""What the language server answers besides diagnostics, as plain data over a workspace's
analyses: hover (an assumption: whether it holds and why; a name: where it is declared),
document symbols, completion of names where the grammar expects one, and formatting."""
from __future__ import annotations

import re
from dataclasses import dataclass, replace
from functools import lru_cache
from typing import Iterable, Optional

from checker.editor import index as idx
from checker.editor.workspace import Analysis
from checker.reports.report import explanation
from checker.semantic_model.semantics import AssumptionResult, support
from reconf_dsl import ir
from reconf_dsl.diagnostics import DiagnosticError
from reconf_dsl.formatter import format_document
from reconf_dsl.parser import Parser, parse_text
from reconf_dsl.resolve import KNOWN_APPLICATION, KNOWN_FAULTS, KNOWN_FTMS
from reconf_dsl.span import Span


def index_of(analysis: Analysis) -> idx.Index:
    """The analysis's index of names, made on first use."""
    if analysis.index is None:
        analysis.index = idx.build(analysis.documents, analysis.document_texts)
    return analysis.index  # type: ignore[no-any-return]


def _inside(span: Span, line: int, col: int) -> bool:
    return (span.line, span.col) <= (line, col) <= (span.end_line, span.end_col)


def assumption_at(analysis: Analysis, shown: str, line: int, col: int) -> Optional[AssumptionResult]:
    """The assumption written at (line, col) of the file shown as `shown`, as the Python engine judged it."""
    if analysis.outcome is None:
        return None
    for r in analysis.outcome.judged.python.results:
        span = r.assumption.span
        if span.file == shown and _inside(span, line, col):
            return r
    return None


def hover_assumption(r: AssumptionResult, analysis: Analysis) -> str:
    """Whether `r` holds and why: the chain `reconf check` shows when it does not, and what
    provides it (inputs, connectors, outputs, the environment) when it does."""
    if r.holds and analysis.system is not None and analysis.outcome is not None:
        system = analysis.system
        comp = system.component(r.component)
        func = next((f for f in comp.functionalities if f.name == r.functionality), None) if comp else None
        if comp is not None and func is not None:
            config = analysis.outcome.judged.python.config
            r = replace(r, chain=tuple(support(system, config, comp, func, r.assumption)))
    verdict = "✓ holds" if r.holds else "✗ does not hold"
    return (f"**{r.component}.{r.functionality}** assumes `{r.assumption}`: {verdict}\n\n"
            "```text\n" + explanation(r) + "\n```")


KIND_WORDS = {"component": "component", "port": "port", "functionality": "functionality", "connector": "connector",
              "message": "message type", "host": "host", "environment": "environment guarantee"}


def hover_name(key: idx.Key, decls: list[idx.Occurrence], line_text: Optional[str]) -> str:
    what = KIND_WORDS.get(key[0], key[0])
    name = ".".join(key[1:])
    if not decls:
        return f"{what} `{name}`: declared nowhere in this system"
    shown = f"\n\n```text\n{line_text.strip()}\n```" if line_text else ""
    return f"{what} `{name}`, declared at line {decls[0].line}" + shown


@dataclass(frozen=True)
class Symbol:
    """A document symbol: a declaration, its span, its name's place, and what it holds."""

    name: str
    kind: str
    span: Span
    selection: Optional[idx.Occurrence]
    children: tuple["Symbol", ...] = ()


def symbols(doc: ir.Document, index: idx.Index, path: str) -> list[Symbol]:
    decls = {o.key: o for o in index.by_file.get(path, []) if o.decl}
    out: list[Symbol] = []
    for item in doc.items:
        if isinstance(item, ir.Component):
            kids = [Symbol(p.name, p.kind, p.span, decls.get(("port", item.name, p.name))) for p in item.ports]
            kids += [Symbol(f.name, "functionality", f.span, decls.get(("functionality", item.name, f.name)))
                     for f in item.functionalities]
            out.append(Symbol(item.name, "component", item.span, decls.get(("component", item.name)), tuple(kids)))
        elif isinstance(item, ir.Connector):
            out.append(Symbol(item.name, item.kind, item.span, decls.get(("connector", item.name))))
        elif isinstance(item, ir.MessageType):
            out.append(Symbol(item.name, "message", item.span, decls.get(("message", item.name))))
        elif isinstance(item, ir.Host):
            out.append(Symbol(item.name, "host", item.span, decls.get(("host", item.name))))
        elif isinstance(item, ir.EnvGuarantee):
            out.append(Symbol(item.name, "environment", item.span, decls.get(("environment", item.name))))
    return out


def formatted(text: str, shown: str) -> Optional[str]:
    """The text in the canonical layout (`reconf fmt`), or None when it does not parse."""
    try:
        return format_document(parse_text(text, shown))
    except DiagnosticError:
        return None


# ---------------------------------------------------------------------------------- completion

@lru_cache(maxsize=1)
def _completion_parser() -> Parser:
    """A parser of its own: completion runs beside the analysis, and a parser is not re-entrant."""
    return Parser()


_PARTIAL = re.compile(r"[~/\w]*\Z")
WINDOW = 4000   # characters before the cursor read for its context


@dataclass(frozen=True)
class Completion:
    label: str
    kind: str          # keyword, component, port, message, host, ftm, fault, application


def complete(text: str, offset: int, analyses: Iterable[Analysis], shown: str, line: int) -> list[Completion]:
    """What may be written at `offset`: the keywords the grammar accepts there, and the names
    of the kind the place asks for (components after `->`, a component's ports after `c.`,
    message types after `:`, hosts after `host` and `on`, ...)."""
    before = text[:offset]
    partial = _PARTIAL.search(before)
    head = before[:len(before) - len(partial.group())] if partial else before
    parser = _completion_parser()
    expected = parser.expected(head)
    out = [Completion(word, "keyword") for t in sorted(expected or ()) for word in parser.keywords.get(t, ())]
    if expected is not None and not expected & {"NAME", "ROS_TYPE"}:
        return out
    window = head[max(0, len(head) - WINDOW):]
    toks = [t.text for t in idx.tokenize(window[window.find("\n") + 1:] if len(head) > WINDOW else window)]
    names = _Names(list(analyses), shown, line)
    return out + [Completion(n, k) for n, k in _names_for(toks, names)]


class _Names:
    """The names a system declares, for completion."""

    def __init__(self, analyses: list[Analysis], shown: str, line: int) -> None:
        self.components: dict[str, ir.Component] = {}
        self.messages: set[str] = set()
        self.hosts: set[str] = set()
        self.here: Optional[ir.Component] = None
        for a in analyses:
            for doc in a.documents.values():
                for item in doc.items:
                    self._add(item, doc.file == shown, line)

    def _add(self, item: ir.Item, this_file: bool, line: int) -> None:
        if isinstance(item, ir.Component):
            self.components.setdefault(item.name, item)
            if item.host:
                self.hosts.add(item.host)
            if this_file and item.span.line <= line and (self.here is None or item.span.line > self.here.span.line):
                self.here = item
        elif isinstance(item, ir.MessageType):
            self.messages.add(item.name)
        elif isinstance(item, ir.Host):
            self.hosts.add(item.name)

    def ports(self, component: Optional[str] = None) -> list[str]:
        c = self.components.get(component) if component else self.here
        return [p.name for p in c.ports] if c else []


def _names_for(toks: list[str], names: _Names) -> list[tuple[str, str]]:
    last = toks[-1] if toks else ""
    before = toks[-2] if len(toks) > 1 else ""
    recent = toks[-12:]
    if last == "." and before:
        return [(p, "port") for p in names.ports(before)]
    if last in ("->", "{", ",") and _in_connector(toks):
        return [(c, "component") for c in sorted(names.components) if not names.components[c].replaces]
    if last == "replaces":
        return [(c, "component") for c in sorted(names.components)]
    if last == "host" or last == "on" or (last == "," and "on" in recent):
        return [(h, "host") for h in sorted(names.hosts)]
    if last == "ftm" or (last == "(" and "ftm" in recent):
        return [(f, "ftm") for f in sorted(KNOWN_FTMS)]
    if last in ("faults", ",") and "faults" in recent:
        return [(f, "fault") for f in sorted(KNOWN_FAULTS)]
    if last in ("application", ",") and "application" in recent:
        return [(a, "application") for a in sorted(KNOWN_APPLICATION)]
    if last == "takes" or (last == "," and "takes" in recent[-8:]):
        return [(a, "action") for a in ir.ACTIONS]
    if last in ("(", ",") and "functionality" in recent:
        return [(p, "port") for p in names.ports()]
    if last in (":", "assume", "="):
        return [(m, "message") for m in sorted(names.messages)] if last != "=" else []
    return []


def _in_connector(toks: list[str]) -> bool:
    """Whether the innermost open brace of `toks` opens a topic or a service."""
    depth = 0
    for i in range(len(toks) - 1, -1, -1):
        if toks[i] == "}":
            depth += 1
        elif toks[i] == "{":
            if depth == 0:
                head = toks[max(0, i - 8):i]
                return "topic" in head or "service" in head
            depth -= 1
    return False
