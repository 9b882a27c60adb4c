"""A fast lexer for the grammar, driven by the LALR parser state.

Lark's contextual lexer is correct but spends most of a parse in per-token bookkeeping.
This one scans with a single compiled regular expression and decides only what needs the
parser: whether a word is a keyword or a name. A keyword counts as a keyword only where
the parser can accept it, so keywords stay usable as names everywhere else (as with Lark's
contextual lexer). Comments are collected for the formatter.
"""
from __future__ import annotations

import re
from typing import Any, Iterator

from lark import Token
from lark.exceptions import UnexpectedCharacters
from lark.lexer import Lexer, LexerState, PatternStr

MASTER = re.compile(r"""
  (?P<WS>[ \t\r\n\f\v]+)
| (?P<LINE_COMMENT>(?://|\#)[^\n]*)
| (?P<BLOCK_COMMENT>/\*(?:.|\n)*?\*/)
| (?P<STRING>"(?:[^"\\\n]|\\[^\n])*")
| (?P<ARROW>->)
| (?P<ROS_NAME>~?/[^\W\d]\w*(?:/[^\W\d]\w*)*)
| (?P<NUMBER>[+-]?(?:\d+(?:\.\d*)?|\.\d+)(?:[eE][+-]?\d+)?)
| (?P<WORD>[^\W\d]\w*(?:/[^\W\d]\w*)*)
| (?P<PUNCT>[{}():,.=@])
""", re.VERBOSE)

NAMED_WORDS = {"normal": "MODE_KIND", "degraded": "MODE_KIND", "nothing": "NOTHING", "single": "SINGLE"}


class FastLexer(Lexer):
    __future_interface__ = 1

    def __init__(self, conf: Any) -> None:
        self.literals: dict[str, str] = {}
        for t in conf.terminals:
            if isinstance(t.pattern, PatternStr):
                self.literals[t.pattern.value] = t.name
        self.comments: list[Token] = []

    def lex(self, lexer_state: LexerState, parser_state: Any) -> Iterator[Token]:
        text: str = getattr(lexer_state.text, "text", None) or str(lexer_state.text)
        states = parser_state.parse_conf.states
        literals = self.literals
        match = MASTER.match
        pos, line, line_start, end = 0, 1, 0, len(text)
        while pos < end:
            m = match(text, pos)
            if m is None:
                accepts = states[parser_state.position]
                raise UnexpectedCharacters(text, pos, line, pos - line_start + 1,
                                           allowed={k for k in accepts if k.isupper()},
                                           state=parser_state.position)
            kind = m.lastgroup or ""
            value = m.group()
            start, pos = pos, m.end()
            col = start - line_start + 1
            if kind == "WS" or kind == "BLOCK_COMMENT":
                nl = value.count("\n")
                if kind == "BLOCK_COMMENT":
                    end_col = (len(value) - value.rfind("\n")) if nl else col + len(value)
                    self.comments.append(Token(kind, value, start, line, col, line + nl, end_col, pos))
                if nl:
                    line += nl
                    line_start = start + value.rfind("\n") + 1
                continue
            if kind == "LINE_COMMENT":
                self.comments.append(Token(kind, value, start, line, col, line, col + len(value), pos))
                continue
            if kind == "WORD":
                kind = self._word(value, states[parser_state.position])
            elif kind == "PUNCT":
                kind = literals[value]
            yield Token(kind, value, start, line, col, line, col + len(value), pos)

    def _word(self, word: str, accepts: dict[str, Any]) -> str:
        if "/" in word:
            return "ROS_TYPE"
        keyword = self.literals.get(word) or NAMED_WORDS.get(word)
        if keyword is not None and keyword in accepts:
            return keyword
        if "NAME" in accepts or "ROS_TYPE" not in accepts:
            return "NAME"
        return "ROS_TYPE"
