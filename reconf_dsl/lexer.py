"""Lexing and the LALR driver: the grammar's parse table, run by one tight loop.

Lark compiles `grammar.lark` into an LALR(1) table and the rule callbacks; this module
runs them. The lexer scans with a single compiled regular expression and decides only what
needs the parser: whether a word is a keyword or a name. A keyword counts as a keyword only
where the parser state can accept it, so keywords stay usable as names everywhere else (as
with Lark's contextual lexer). Lexing and parsing share one loop, which is what makes large
files fast; comments are collected for the formatter.

The loop keeps its own stacks, so no input makes it recurse; what is built from nested
parentheses (FTM expressions like `SEC(PBR(TR))`) is recursive data, so their depth is
bounded here: a `(` deeper than `MAX_NESTING` raises `TooDeep`.
"""
from __future__ import annotations

import os
import re
from typing import Any, Optional

from lark import Lark, Token
from lark.exceptions import UnexpectedCharacters, UnexpectedToken
from lark.lexer import PatternStr
from lark.parsers.lalr_analysis import Shift

from .span import Span

# Every repetition of a group is possessive (`*+`) and the block comment repeats one character
# class: a repeated group that may backtrack costs the regular expression engine memory for
# each repetition, which a 64 MiB string or comment would exhaust.
MASTER = re.compile(r"""
[ \t\r\n\f\v]*
(?:
  (?P<END>\Z)
| (?P<LINE_COMMENT>(?://|\#)[^\n]*)
| (?P<BLOCK_COMMENT>/\*[\s\S]*?\*/)
| (?P<STRING>"(?:[^"\\\n]|\\[^\n])*+")
| (?P<ARROW>->)
| (?P<ROS_NAME>~?/[^\W\d]\w*(?:/[^\W\d]\w*)*+)
| (?P<NUMBER>[+-]?(?:\d+(?:\.\d*)?|\.\d+)(?:[eE][+-]?\d+)?)
| (?P<WORD>[^\W\d]\w*(?:/[^\W\d]\w*)*+)
| (?P<PUNCT>[{}():,.=@])
)""", re.VERBOSE)

MAX_NESTING = 64  # parentheses open at once (RC018)

NAMED_WORDS = {"normal": "MODE_KIND", "degraded": "MODE_KIND", "nothing": "NOTHING", "single": "SINGLE"}
_SPACE = re.compile(r"[ \t\r\n\f\v]*")


class Comment(tuple[int, int, str]):
    """A comment as `Document.comments` holds it, (first line, last line, text), with what the
    formatter needs to keep it in place: its first and (exclusive) last column; `trailing`, a token
    is before it on its first line; `glued`, it starts on the line the comment before it ends on,
    with no token between; `blank_before` / `blank_after`, an empty line separates it from what is
    before / after it; `next`, the line, column and text of the token after it (None at the end)."""

    col: int
    end_col: int
    trailing: bool
    glued: bool
    blank_before: bool
    blank_after: bool
    next: Optional[tuple[int, int, str]]

    def __new__(cls, text: str, line: int, col: int, end_line: int, end_col: int, *, trailing: bool = False,
                glued: bool = False, blank_before: bool = False, blank_after: bool = False) -> "Comment":
        self = super().__new__(cls, (line, end_line, text))
        self.col, self.end_col = col, end_col
        self.trailing, self.glued, self.blank_before, self.blank_after = trailing, glued, blank_before, blank_after
        self.next = None
        return self

    @property
    def text(self) -> str:
        return self[2]

    @property
    def start(self) -> tuple[int, int]:
        return (self[0], self.col)

    @property
    def end(self) -> tuple[int, int]:
        return (self[1], self.end_col)


def _comment(text: str, value: str, line: int, col: int, pos: int, newlines_before: int, last: Optional[Token],
             earlier: list[Comment]) -> Comment:
    """The comment `value` at `line`:`col` of `text`, ending at offset `pos`, after `newlines_before`
    line breaks of white space, the token `last` and the comments `earlier`."""
    nl = value.count("\n")
    end_col = (len(value) - value.rfind("\n")) if nl else col + len(value)
    prev = earlier[-1] if earlier else None
    glued = prev is not None and prev[1] == line and (last is None or prev.start > (last.line, last.column))
    after = _SPACE.match(text, pos)
    blank_after = after is not None and after.end() < len(text) and after.group().count("\n") >= 2
    return Comment(value, line, col, line + nl, end_col, trailing=last is not None and last.line == line,
                   glued=glued, blank_before=newlines_before >= 2 and (last is not None or prev is not None),
                   blank_after=blank_after)


def _token(kind: str, value: str, start: int, line: int, col: int, end_col: int, pos: int,
           _new: Any = str.__new__) -> Token:
    """A one-line Token, built without Lark's general (and slower) constructor."""
    t: Any = _new(Token, value)
    t.type, t.value, t.start_pos, t.line, t.column = kind, value, start, line, col
    t.end_line, t.end_column, t.end_pos = line, end_col, pos
    return t  # type: ignore[no-any-return]


class TooDeep(Exception):
    """A `(` opened more than `MAX_NESTING` parentheses deep."""

    def __init__(self, token: Token) -> None:
        self.token = token
        super().__init__(f"more than {MAX_NESTING} nested parentheses at {token.line}:{token.column}")


class Driver:
    """Parses text with the table and callbacks Lark built for the grammar."""

    def __init__(self, lark: Lark) -> None:
        frontend: Any = lark.parser
        lalr = frontend.parser.parser
        table = lalr.parse_table
        self.states: dict[int, dict[str, tuple[Any, Any]]] = table.states
        self.start: int = table.start_states["start"]
        self.end: int = table.end_states["start"]
        self.callbacks: dict[Any, Any] = lalr.callbacks
        self.literals: dict[str, str] = {t.pattern.value: t.name for t in lark.terminals
                                         if isinstance(t.pattern, PatternStr)}
        self.comments: list[Comment] = []

    # One loop on purpose: it runs once per token of every file, and a call per token is what it avoids.
    def parse(self, text: str) -> Any:
        states, callbacks, literals = self.states, self.callbacks, self.literals
        comments = self.comments
        match = MASTER.match
        state_stack: list[int] = [self.start]
        value_stack: list[Any] = []
        pos, line, line_start, end = 0, 1, 0, len(text)
        depth = 0  # parentheses open
        last: Optional[Token] = None
        new_token = _token
        waiting = 0  # comments since the last token, which do not know the token after them yet
        while True:
            m = match(text, pos) if pos < end else None
            if m is not None and m.lastgroup != "END":
                kind = m.lastgroup or ""
                start = m.start(kind)
                nl = text.count("\n", pos, start)
                if nl:
                    line += nl
                    line_start = text.rindex("\n", pos, start) + 1
                value = m.group(kind)
                pos = m.end()
                col = start - line_start + 1
                if kind == "BLOCK_COMMENT" or kind == "LINE_COMMENT":
                    comments.append(_comment(text, value, line, col, pos, nl, last, comments))
                    waiting += 1
                    nl = value.count("\n")
                    if nl:
                        line += nl
                        line_start = start + value.rfind("\n") + 1
                    continue
                if kind == "WORD":
                    kind = self._word(value, states[state_stack[-1]])
                elif kind == "PUNCT":
                    kind = literals[value]
                    if value == "(":
                        depth += 1
                        if depth > MAX_NESTING:
                            raise TooDeep(new_token(kind, value, start, line, col, col + 1, pos))
                    elif value == ")":
                        depth -= 1
                token = new_token(kind, value, start, line, col, col + len(value), pos)
                last = token
                if waiting:
                    for c in comments[-waiting:]:
                        c.next = (line, col, value)
                    waiting = 0
                is_end = False
            elif m is None and pos < end:
                rest = text[pos:]
                at = pos + len(rest) - len(rest.lstrip(" \t\r\n\f\v"))
                line += text.count("\n", pos, at)
                if "\n" in text[pos:at]:
                    line_start = text.rindex("\n", pos, at) + 1
                accepts = states[state_stack[-1]]
                raise UnexpectedCharacters(text, at, line, at - line_start + 1,
                                           allowed={k for k in accepts if k.isupper()})
            else:
                pos = end
                token = Token.new_borrow_pos("$END", "", last) if last else Token("$END", "", 0, 1, 1)
                is_end = True
            while True:
                actions = states[state_stack[-1]]
                try:
                    action, arg = actions[token.type]
                except KeyError:
                    raise UnexpectedToken(token, {s for s in actions if s.isupper()}) from None
                if action is Shift:
                    state_stack.append(arg)
                    value_stack.append(token)
                    break
                size = len(arg.expansion)
                if size:
                    children = value_stack[-size:]
                    del state_stack[-size:]
                    del value_stack[-size:]
                else:
                    children = []
                state_stack.append(states[state_stack[-1]][arg.origin.name][1])
                value_stack.append(callbacks[arg](children))
                if is_end and state_stack[-1] == self.end:
                    return value_stack[-1]

    def _word(self, word: str, accepts: dict[str, Any]) -> str:
        if "/" in word:
            return "ROS_TYPE"
        keyword = self.literals.get(word) or NAMED_WORDS.get(word)
        if keyword is not None and keyword in accepts:
            return keyword
        if "NAME" in accepts or "ROS_TYPE" not in accepts:
            return "NAME"
        return "ROS_TYPE"


PURE_ENV = "RECONF_PURE_PARSER"   # set (to anything but "" or 0): the Python driver, even where the compiled one is built


def compiled_driver_available() -> bool:
    """Whether the compiled driver (`_fastparse`, built by `make` from `_fastparse.pyx`) imports here."""
    try:
        from . import _fastparse  # noqa: F401
    except ImportError:
        return False
    return True


def make_driver(lark: Lark, target: Any, rules: tuple[str, ...], meaningful: frozenset[str]) -> Any:
    """The compiled driver where it is built and not turned off by RECONF_PURE_PARSER, else the
    Python one (`Driver`, which reaches `target`'s methods through Lark's callbacks). Either
    gives the same documents, comments and errors."""
    if os.environ.get(PURE_ENV, "") in ("", "0"):
        try:
            from ._fastparse import FastDriver
        except ImportError:
            pass
        else:
            return FastDriver(lark, target, rules, meaningful, NAMED_WORDS, MAX_NESTING, _comment, TooDeep, Span)
    return Driver(lark)


def driver_kind(driver: Any) -> str:
    """"compiled" or "python": which driver parses (for timing lines and benchmarks)."""
    return "python" if isinstance(driver, Driver) else "compiled"
