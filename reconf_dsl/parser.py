"""Text → `Document`: the Lark parser and the transformer to IR.

Only syntax and what can be judged from one token (units, rate values) is decided here;
names are resolved in `resolve`.
"""
from __future__ import annotations

from fractions import Fraction
from functools import lru_cache
from importlib import resources
from typing import Any, Optional

from lark import Lark, Token
from lark.exceptions import UnexpectedCharacters, UnexpectedEOF, UnexpectedInput, UnexpectedToken
from lark.lexer import PatternStr

from . import ir
from .diagnostics import Diagnostic, DiagnosticError, DiagnosticSink, Related, error, shorten
from .gcpause import gc_paused
from .lexer import MAX_NESTING, NAMED_WORDS, Comment, TooDeep, make_driver
from .span import NO_SPAN, Span, make_span

TERMINAL_NAMES = {
    "NAME": "a name", "ROS_NAME": "a ROS name like /ns/topic", "ROS_TYPE": "a message type like std_msgs/msg/String",
    "NUMBER": "a number", "STRING": 'a "string"', "LBRACE": "'{'", "RBRACE": "'}'", "LPAR": "'('",
    "RPAR": "')'", "COLON": "':'", "COMMA": "','", "DOT": "'.'", "EQUAL": "'='", "AT": "'@'",
    "ARROW": "'->'", "MODE_KIND": "'normal' or 'degraded'", "NOTHING": "'nothing'", "SINGLE": "'single'",
    "$END": "end of file",
}


class Located(str):
    """A string the IR keeps without a node of its own (a component's `run` command or `host`),
    with the span of the statement that gave it, for the formatter to keep comments beside it.
    It is equal to the plain string, as spans take no part in equality."""

    span: Span

    def __new__(cls, value: str, span: Span = NO_SPAN) -> "Located":
        self = super().__new__(cls, value)
        self.span = span
        return self


class LocatedTuple(tuple[Any, ...]):
    """`Located` for a tuple: a component's `faults`, `application` or `resources`, with the span of
    the (first) statement that gave it."""

    span: Span

    def __new__(cls, items: Any = (), span: Span = NO_SPAN) -> "LocatedTuple":
        self = super().__new__(cls, items)
        self.span = span
        return self


def _describe(terminal: str) -> str:
    if terminal in TERMINAL_NAMES:
        return TERMINAL_NAMES[terminal]
    if terminal.startswith("__ANON") or terminal.isupper():
        return terminal.lower()
    return terminal


class _ToIR:
    """Builds IR nodes bottom-up while the LALR parser runs (no parse tree is built).

    Lark calls one method per rule with every token kept; `_callbacks` computes the rule's
    source region from its first and last tokens and drops the punctuation and keywords.
    """

    def __init__(self) -> None:
        self.file = "<input>"
        self.sink = DiagnosticSink()

    def span_of(self, meta: Optional[tuple[int, int, int, int]]) -> Span:
        if meta is None:
            return make_span(self.file, 1, 1, 1, 1)
        return make_span(self.file, meta[0], meta[1], meta[2], meta[3])

    def tok(self, t: Token) -> Span:
        return make_span(self.file, t.line or 1, t.column or 1, t.end_line or t.line or 1,
                         t.end_column or t.column or 1)

    def start(self, meta: Any, items: list[Any]) -> list[Any]:
        return items

    def system_decl(self, meta: Any, c: list[Token]) -> tuple[str, str, Span]:
        return ("system", str(c[0]), self.span_of(meta))

    def include_decl(self, meta: Any, c: list[Token]) -> ir.Include:
        return ir.Include(unquote(c[0]), self.span_of(meta))

    def message_decl(self, meta: Any, c: list[Token]) -> ir.MessageType:
        return ir.MessageType(str(c[0]), str(c[1]), self.span_of(meta))

    def environment_decl(self, meta: Any, c: list[Any]) -> ir.EnvGuarantee:
        return ir.EnvGuarantee(str(c[0]), c[1], self.span_of(meta))

    def host_decl(self, meta: Any, c: list[Any]) -> ir.Host:
        return ir.Host(str(c[0]), tuple(c[1:]), self.span_of(meta))

    def resource_item(self, meta: Any, c: list[Token]) -> ir.ResourceSetting:
        return ir.ResourceSetting(str(c[0]), str(c[1]), self.span_of(meta))

    def component_decl(self, meta: Any, c: list[Any]) -> ir.Component:
        name = str(c[0])
        fields: dict[str, Any] = {"ports": [], "functionalities": []}
        for stmt in c[1:]:
            kind, value = stmt
            if kind == "node" and "node" in fields:
                self.sink.add(error("RC130", "a component is one node: a second `node` block", value.span,
                                    related=(Related(fields["node"].span, "the first one"),)))
            if kind in ("ports", "functionalities"):
                fields[kind].append(value)
            elif kind in ("faults", "application", "resources", "takes") and kind in fields:
                fields[kind] = LocatedTuple(fields[kind] + value, fields[kind].span)  # where the first one was
            else:
                fields[kind] = value
        for key in ("ports", "functionalities"):
            fields[key] = tuple(fields[key])
        return ir.Component(name=name, span=self.span_of(meta), **fields)

    def replaces(self, meta: Any, c: list[Token]) -> tuple[str, str]:
        return ("replaces", str(c[0]))

    def run_stmt(self, meta: Any, c: list[Token]) -> tuple[str, str]:
        return ("run", Located(unquote(c[0]), self.span_of(meta)))

    def host_stmt(self, meta: Any, c: list[Token]) -> tuple[str, str]:
        return ("host", Located(str(c[0]), self.span_of(meta)))

    def node_stmt(self, meta: Any, c: list[Any]) -> tuple[str, ir.RosNode]:
        lifecycle = len(c) > 1 and c[1] == ("lifecycle",)
        items = c[2:] if lifecycle else c[1:]
        return ("node", ir.RosNode(str(c[0]), lifecycle, tuple(x for x in items if isinstance(x, ir.NodeTopic)),
                                   tuple(x for x in items if isinstance(x, ir.NodeMode)), self.span_of(meta)))

    def node_kind(self, meta: Any, c: list[Any]) -> tuple[str]:
        return ("lifecycle",)

    def node_topic(self, meta: Any, c: list[Any]) -> ir.NodeTopic:
        return ir.NodeTopic(str(c[0]), str(c[1]), self.span_of(meta))

    def node_mode(self, meta: Any, c: list[Any]) -> ir.NodeMode:
        return ir.NodeMode(str(c[0]), str(c[1]), tuple(c[2:]), self.span_of(meta))  # type: ignore[arg-type]

    def effect_deactivate(self, meta: Any, c: list[Any]) -> ir.Effect:
        return ir.Effect("deactivate", span=self.span_of(meta))

    def effect_hold(self, meta: Any, c: list[Any]) -> ir.Effect:
        return ir.Effect("hold", span=self.span_of(meta))

    def effect_set(self, meta: Any, c: list[Any]) -> ir.Effect:
        return ir.Effect("set", c[0], c[1], self.span_of(meta))

    def param_name(self, meta: Any, c: list[Token]) -> str:
        return ".".join(str(t) for t in c)

    def param_value(self, meta: Any, c: list[Token]) -> ir.ParamValue:
        tok = c[0]
        text = str(tok)
        if tok.type == "STRING":
            return unquote(tok)
        if tok.type == "NAME":
            if text in ("true", "false"):
                return text == "true"
            self.sink.add(error("RC131", f"a parameter value is a number, a \"string\", true or false, not "
                                         f"{shorten(text, 40)}", self.tok(tok)))
            return text
        value = param_number(text)
        if value is None:
            self.sink.add(error("RC131", f"'{shorten(text, MAX_NUMBER_CHARS)}' is not a parameter value ROS 2 can "
                                         "hold", self.tok(tok),
                                notes=("a whole number fits in 64 bits, any other is a finite double",)))
            return 0
        return value

    def input_stmt(self, meta: Any, c: list[Any]) -> tuple[str, ir.Port]:
        pred: ir.Predicate = c[1]
        return ("ports", ir.Port(str(c[0]), "input", pred.message or "", pred, self.span_of(meta)))

    def output_stmt(self, meta: Any, c: list[Token]) -> tuple[str, ir.Port]:
        return ("ports", ir.Port(str(c[0]), "output", str(c[1]), None, self.span_of(meta)))

    def faults_stmt(self, meta: Any, c: list[Any]) -> tuple[str, tuple[str, ...]]:
        return ("faults", LocatedTuple(c[0], self.span_of(meta)))

    def application_stmt(self, meta: Any, c: list[Any]) -> tuple[str, tuple[str, ...]]:
        return ("application", LocatedTuple(c[0], self.span_of(meta)))

    def resources_stmt(self, meta: Any, c: list[Any]) -> tuple[str, tuple[ir.ResourceSetting, ...]]:
        return ("resources", LocatedTuple(c, self.span_of(meta)))

    def ftm_stmt(self, meta: Any, c: list[Any]) -> tuple[str, ir.FtmDecl]:
        hosts = c[1] if len(c) > 1 else ()
        return ("ftm", ir.FtmDecl(c[0], hosts, self.span_of(meta)))

    def takes_stmt(self, meta: Any, c: list[Any]) -> tuple[str, tuple[ir.Take, ...]]:
        return ("takes", LocatedTuple([t for t in c if t is not None], self.span_of(meta)))

    def take_item(self, meta: Any, c: list[Token]) -> Optional[ir.Take]:
        action, digits, unit = c
        value = number(str(digits))
        if str(action) not in ir.ACTIONS:
            self.sink.add(error("RC133", f"'{shorten(str(action), MAX_NUMBER_CHARS)}' is not an action",
                                self.tok(action), notes=("the actions: " + ", ".join(ir.ACTIONS),)))
        elif value is None or value < 0:
            self.sink.add(error("RC133", f"'{shorten(str(digits), MAX_NUMBER_CHARS)}' is not a time an action takes",
                                self.tok(digits), notes=(NUMBER_RANGE,)))
        elif str(unit) not in ("s", "ms"):
            self.sink.add(error("RC133", f"unknown unit '{shorten(str(unit), MAX_NUMBER_CHARS)}'", self.tok(unit),
                                notes=("an action's time is in s or ms",)))
        else:
            return ir.Take(str(action), value, str(unit), self.span_of(meta))
        return None

    def ftm_hosts(self, meta: Any, c: list[Any]) -> tuple[str, ...]:
        return tuple(c[0])

    def ftm_expr(self, meta: Any, c: list[Any]) -> ir.FtmExpr:
        return ir.FtmExpr(str(c[0]), c[1] if len(c) > 1 else None, self.span_of(meta))

    def functionality(self, meta: Any, c: list[Any]) -> tuple[str, ir.Functionality]:
        name = str(c[0])
        ports: tuple[str, ...] = ()
        criticality = 1
        modes: dict[str, ir.Mode] = {}
        span = self.span_of(meta)
        for x in c[1:]:
            if x is None:
                continue
            if isinstance(x, tuple) and x and x[0] == "criticality":
                criticality = x[1]
            elif isinstance(x, ir.Mode):
                if x.kind in modes:
                    self.sink.add(error("RC110", f"functionality '{name}' has two {x.kind} modes", x.span))
                modes[x.kind] = x
            else:
                ports = tuple(x)
        return ("functionalities", ir.Functionality(name, ports, modes.get("normal"), modes.get("degraded"),
                                                    criticality, span))

    def criticality(self, meta: Any, c: list[Token]) -> tuple[str, int]:
        tok = c[0]
        value = number(str(tok))
        if value is None or value.denominator != 1 or value < 0:
            shown = shorten(str(tok), MAX_NUMBER_CHARS)
            self.sink.add(error("RC119", f"criticality must be a whole number ≥ 0, not {shown}",
                                self.tok(tok), notes=(NUMBER_RANGE,) if value is None else ()))
            return ("criticality", 1)
        return ("criticality", int(value))

    def mode(self, meta: Any, c: list[Any]) -> ir.Mode:
        kind = str(c[0])
        asms = tuple(x for x in c[1:] if isinstance(x, ir.Predicate))
        guars = tuple(x for x in c[1:] if isinstance(x, ir.Guarantee))
        return ir.Mode(kind, asms, guars, self.span_of(meta))  # type: ignore[arg-type]

    def assume_stmt(self, meta: Any, c: list[Any]) -> ir.Predicate:
        return c[0]  # type: ignore[no-any-return]

    def guarantee_stmt(self, meta: Any, c: list[Any]) -> ir.Guarantee:
        return ir.Guarantee(str(c[0]), c[1], self.span_of(meta))

    def nothing(self, meta: Any, c: list[Any]) -> ir.Predicate:
        return ir.Predicate(None, None, self.span_of(meta))

    def data(self, meta: Any, c: list[Any]) -> ir.Predicate:
        rate = c[1] if len(c) > 1 else None
        return ir.Predicate(str(c[0]), rate, self.span_of(meta))

    def rate(self, meta: Any, c: list[Token]) -> Optional[ir.Rate]:
        digits, unit = c
        span = self.span_of(meta)
        value = number(str(digits))
        if value is None:
            self.sink.add(error("RC113", f"'{shorten(str(digits), MAX_NUMBER_CHARS)}' is not a rate", self.tok(digits),
                                notes=(NUMBER_RANGE,)))
            return ir.Rate(Fraction(1), "Hz", span)
        if str(unit) not in ir.UNITS:
            self.sink.add(error("RC114", f"unknown unit '{shorten(str(unit), MAX_NUMBER_CHARS)}'", self.tok(unit),
                                notes=("rates are in Hz, kHz or MHz, or a period in s, ms or us",)))
            return ir.Rate(value if value > 0 else Fraction(1), "Hz", span)
        if value <= 0:
            self.sink.add(error("RC113", f"a rate must be positive, not {digits} {unit}", self.tok(digits)))
            return ir.Rate(Fraction(1), str(unit), span)
        return ir.Rate(value, str(unit), span)

    def topic_decl(self, meta: Any, c: list[Any]) -> ir.Connector:
        return self._connector("topic", meta, c)

    def service_decl(self, meta: Any, c: list[Any]) -> ir.Connector:
        return self._connector("service", meta, c)

    def _connector(self, kind: str, meta: Any, c: list[Any]) -> ir.Connector:
        name, pred = c[0], c[1]
        single = False
        pubs: list[ir.PortRef] = []
        subs: list[ir.PortRef] = []
        for x in c[2:]:
            if isinstance(x, Token) and x.type == "SINGLE":
                single = True
            else:
                pubs.extend(x[0])
                subs.extend(x[1])
        return ir.Connector(name, kind, pred, single, tuple(pubs), tuple(subs), self.span_of(meta))  # type: ignore[arg-type]

    def conn_name(self, meta: Any, c: list[Token]) -> str:
        return str(c[0])

    def attachment(self, meta: Any, c: list[Any]) -> tuple[list[ir.PortRef], list[ir.PortRef]]:
        left: list[ir.PortRef] = []
        right: list[ir.PortRef] = []
        seen_arrow = False
        for x in c:
            if isinstance(x, Token):
                seen_arrow = True
            elif x is not None:
                (right if seen_arrow else left).extend(x)
        return left, right

    def portref_list(self, meta: Any, c: list[ir.PortRef]) -> list[ir.PortRef]:
        return list(c)

    def portref(self, meta: Any, c: list[Token]) -> ir.PortRef:
        return ir.PortRef(str(c[0]), str(c[1]), self.span_of(meta))

    def name_list(self, meta: Any, c: list[Token]) -> tuple[str, ...]:
        return tuple(str(t) for t in c)


_ESCAPES = {"n": "\n", "t": "\t", '"': '"', "\\": "\\"}

MAX_NUMBER_CHARS = 32  # a number's text; longer ones are refused, not computed
MAX_EXPONENT = 32      # |e| of 1e-9 or 2.5E3; Fraction would compute 10**e, however large
NUMBER_RANGE = (f"a number has at most {MAX_NUMBER_CHARS} characters and an exponent between "
                f"-{MAX_EXPONENT} and {MAX_EXPONENT}")


@lru_cache(maxsize=4096)
def number(text: str) -> Optional[Fraction]:
    """The value of a NUMBER token, or None when it is out of range or malformed (kept for the
    next time: a file writes the same few rates thousands of times, and a Fraction is immutable)."""
    if len(text) > MAX_NUMBER_CHARS:
        return None
    _, e, exponent = text.lower().partition("e")
    try:
        if e and abs(int(exponent)) > MAX_EXPONENT:
            return None
        return Fraction(text)
    except (ValueError, ZeroDivisionError):
        return None


INT64 = 2 ** 63


def param_number(text: str) -> Optional[int | float]:
    """A NUMBER as a parameter value: an integer (int64) without `.` or an exponent, else a finite
    double; None when ROS 2 cannot hold it."""
    if len(text) > MAX_NUMBER_CHARS:
        return None
    if any(ch in text for ch in ".eE"):
        value = float(text)
        return value if abs(value) != float("inf") else None
    whole = int(text)
    return whole if -INT64 <= whole < INT64 else None


# Terminals that carry meaning; every other token (keywords, punctuation) only marks position.
MEANINGFUL = frozenset({"NAME", "ROS_NAME", "ROS_TYPE", "NUMBER", "STRING", "MODE_KIND", "NOTHING", "SINGLE",
                        "ARROW"})


def _first(x: Any) -> Optional[tuple[int, int]]:
    if isinstance(x, Token):
        return (x.line or 1, x.column or 1)
    span = getattr(x, "span", None)
    if isinstance(span, Span):
        return (span.line, span.col)
    if isinstance(x, (list, tuple)):
        for y in x:
            found = _first(y)
            if found is not None:
                return found
    return None


def _last(x: Any) -> Optional[tuple[int, int]]:
    if isinstance(x, Token):
        return (x.end_line or x.line or 1, x.end_column or x.column or 1)
    span = getattr(x, "span", None)
    if isinstance(span, Span):
        return (span.end_line, span.end_col)
    if isinstance(x, (list, tuple)):
        for y in reversed(x):
            found = _last(y)
            if found is not None:
                return found
    return None


class _Callbacks:
    """What Lark calls while parsing: one attribute per rule or alias of the grammar."""

    RULES = ("start", "system_decl", "include_decl", "message_decl", "environment_decl", "host_decl",
             "resource_item", "component_decl", "replaces", "run_stmt", "host_stmt", "node_stmt", "node_kind",
             "node_topic", "node_mode", "effect_deactivate", "effect_hold", "effect_set", "param_name", "param_value",
             "input_stmt", "output_stmt",
             "faults_stmt", "application_stmt", "resources_stmt", "ftm_stmt", "ftm_hosts", "ftm_expr",
             "takes_stmt", "take_item",
             "functionality", "criticality", "mode", "assume_stmt", "guarantee_stmt", "nothing", "data", "rate",
             "topic_decl", "service_decl", "conn_name", "attachment", "portref_list", "portref", "name_list")

    def __init__(self, target: _ToIR) -> None:
        for rule in self.RULES:
            setattr(self, rule, self._wrap(getattr(target, rule)))

    @staticmethod
    def _wrap(method: Any) -> Any:
        def callback(children: list[Any]) -> Any:
            if not children:
                return method(None, children)
            a, b = children[0], children[-1]
            first = (a.line, a.column) if type(a) is Token else _first(children)
            last = (b.end_line, b.end_column) if type(b) is Token else _last(children)
            meta = None if first is None or last is None else (first[0], first[1], last[0], last[1])
            return method(meta, [c for c in children if type(c) is not Token or c.type in MEANINGFUL])
        return callback


def unquote(tok: Token) -> str:
    """The text of a "string": \\n, \\t, \\" and \\\\ are escapes; any other backslash stays."""
    body = str(tok)[1:-1]
    if "\\" not in body:
        return body
    out: list[str] = []
    i = 0
    while i < len(body):
        ch = body[i]
        if ch == "\\" and i + 1 < len(body) and body[i + 1] in _ESCAPES:
            out.append(_ESCAPES[body[i + 1]])
            i += 2
        else:
            out.append(ch)
            i += 1
    return "".join(out)


def quote(text: str) -> str:
    """The inverse of `unquote`."""
    return '"' + text.replace("\\", "\\\\").replace('"', '\\"').replace("\n", "\\n").replace("\t", "\\t") + '"'


class Parser:
    """One Lark LALR parser, built once; `parse` is not re-entrant."""

    def __init__(self) -> None:
        grammar = resources.files(__package__).joinpath("grammar.lark").read_text(encoding="utf-8")
        self._ir = _ToIR()
        lark = Lark(grammar, parser="lalr", lexer="basic", keep_all_tokens=True, transformer=_Callbacks(self._ir))
        self._driver = make_driver(lark, self._ir, _Callbacks.RULES, MEANINGFUL)
        self._comments: list[Comment] = self._driver.comments
        spelled: dict[str, list[str]] = {}
        for word, terminal in {**NAMED_WORDS, **{t.pattern.value: t.name for t in lark.terminals
                                                 if isinstance(t.pattern, PatternStr)}}.items():
            if word[:1].isalpha():
                spelled.setdefault(terminal, []).append(word)
        self.keywords = {t: tuple(sorted(w)) for t, w in spelled.items()}
        """Each keyword terminal's spellings (`MODE_KIND`: degraded, normal), from the grammar."""

    def expected(self, text: str) -> Optional[frozenset[str]]:
        """The terminals the grammar accepts right after `text` (which ends between two tokens),
        or None when `text` goes wrong before its end: for completion in an editor."""
        self._ir.file, self._ir.sink = "<completion>", DiagnosticSink()
        self._comments.clear()
        try:
            with gc_paused():
                self._driver.parse(text + "\0")
        except UnexpectedCharacters as e:
            if e.pos_in_stream == len(text):
                return frozenset(e.allowed or ())
        except (UnexpectedInput, TooDeep):
            pass
        return None

    def parse(self, text: str, file: str) -> ir.Document:
        """Parse one file. Raises DiagnosticError on any error."""
        self._ir.file = file
        self._ir.sink = DiagnosticSink()
        self._comments.clear()
        try:
            with gc_paused():
                items: list[Any] = self._driver.parse(text)
        except UnexpectedInput as e:
            raise DiagnosticError([syntax_diagnostic(e, text, file)]) from None
        except TooDeep as e:
            raise DiagnosticError([error("RC018", f"more than {MAX_NESTING} nested parentheses",
                                         self._ir.tok(e.token),
                                         notes=(f"expressions nest at most {MAX_NESTING} deep; "
                                                "SEC(PBR(TR)) nests 2",))]) from None
        self._ir.sink.raise_if_errors()
        system: Optional[str] = None
        system_span = Span(file, 1, 1, 1, 1)
        body: list[ir.Item] = []
        sink = DiagnosticSink()
        for item in items:
            if isinstance(item, tuple) and item[0] == "system":
                if system is not None:
                    sink.add(error("RC115", f"a file declares one system; '{system}' is already declared here",
                                   item[2], related=(_rel(system_span, "first declared here"),)))
                system, system_span = item[1], item[2]
            else:
                body.append(item)
        sink.raise_if_errors()
        return ir.Document(file, system, tuple(body), system_span, tuple(self._comments))


def _rel(span: Span, msg: str) -> Related:
    return Related(span, msg)


def syntax_diagnostic(e: UnexpectedInput, text: str, file: str) -> Diagnostic:
    line, col = e.line if e.line > 0 else 1, e.column if e.column > 0 else 1
    if isinstance(e, UnexpectedCharacters):
        at = e.pos_in_stream or 0
        rest = text[at:at + 2]
        span = Span(file, line, col, line, col + 1)
        if rest.startswith('"'):
            return error("RC003", "unterminated string", span, notes=("a string ends with \" on the same line",))
        if rest.startswith("/*"):
            return error("RC004", "unterminated comment", span, notes=("a /* comment */ needs its closing */",))
        char = text[at] if at < len(text) else ""
        expected = sorted(_describe(t) for t in (e.allowed or ()))
        return error("RC002", f"unexpected character {char!r}", span,
                     notes=(f"expected {_one_of(expected)}",) if expected else ())
    if isinstance(e, UnexpectedToken):
        tok = e.token
        expected = sorted({_describe(t) for t in e.expected if not t.startswith("_")})
        if tok.type == "$END":
            end = _end_position(text)
            return error("RC001", "unexpected end of file", Span(file, *end, *end),
                         notes=(f"expected {_one_of(expected)}",) if expected else ())
        span = Span(file, tok.line or line, tok.column or col, tok.end_line or line,
                    tok.end_column or col + 1)
        return error("RC001", f"unexpected {shorten(str(tok), 60)!r}", span,      # a token may be megabytes long
                     notes=(f"expected {_one_of(expected)}",) if expected else ())
    if isinstance(e, UnexpectedEOF):
        end = _end_position(text)
        return error("RC001", "unexpected end of file", Span(file, *end, *end))
    return error("RC001", str(e), Span(file, line, col, line, col))  # pragma: no cover


def _end_position(text: str) -> tuple[int, int]:
    lines = text.split("\n")
    return len(lines), len(lines[-1]) + 1


def _one_of(names: list[str]) -> str:
    if len(names) > 8:
        names = names[:8] + ["…"]
    return names[0] if len(names) == 1 else "one of " + ", ".join(names)


@lru_cache(maxsize=1)
def parser() -> Parser:
    return Parser()


def parse_text(text: str, file: str = "<input>") -> ir.Document:
    return parser().parse(text, file)
