# cython: language_level=3, boundscheck=False, wraparound=False, initializedcheck=False, cdivision=True
"""The compiled lexer and LALR driver: what `lexer.Driver` does, in C.

Nothing here knows the language. The parse table, the rules and their callbacks come from the
Lark parser built from `grammar.lark` when the parser is made (`FastDriver.__init__` turns Lark's
dictionaries into integer arrays), so a rule added to the grammar needs no change here. What this
module fixes is the token classes the lexer recognises, which are `lexer.MASTER`'s, scanned by
hand: white space, `//` and `#` line comments, `/* */` comments, strings, `->`, ROS names,
numbers, words and one-character punctuation. `tests/test_fast_parser.py` holds the two drivers
to the same documents, comments and diagnostics.

What it saves over the Python driver: tokens that carry no meaning (keywords, punctuation) are
never made into Lark `Token` objects (a `_Bare` keeps their position, for the span of the rule
they start or end), the table is indexed by integers, and Lark's tree-shaping wrappers
(inlining `_rule` helpers, `?rule` with one child, placeholders) are done inline.
"""

from cpython.list cimport PyList_GET_SIZE, PyList_GetSlice
from libc.stdlib cimport free, malloc, realloc

from lark import Token, Tree
from lark.exceptions import UnexpectedCharacters, UnexpectedToken
from lark.lexer import PatternStr
from lark.parsers.lalr_analysis import Shift


cdef extern from "Python.h":
    int PyUnicode_KIND(object o)
    void* PyUnicode_DATA(object o)
    Py_UCS4 PyUnicode_READ(int kind, void* data, Py_ssize_t index)
    bint Py_UNICODE_ISALNUM(Py_UCS4 ch)
    bint Py_UNICODE_ISDECIMAL(Py_UCS4 ch)
    bint Py_UNICODE_ISSPACE(Py_UCS4 ch)


cdef enum:                                  # the token classes of lexer.MASTER
    K_NONE, K_LINE_COMMENT, K_BLOCK_COMMENT, K_STRING, K_ARROW, K_ROS_NAME, K_NUMBER, K_WORD, K_PUNCT

cdef object _str_new = str.__new__


cdef class _Bare:
    """A token no callback sees (a keyword, punctuation): its terminal and where it is."""
    cdef public int term
    cdef public Py_ssize_t start, end, line, col


cdef class _Splice:
    """What a `_helper` rule (Lark's expansion of `x*`) gives its parent: children to inline."""
    cdef public list items


cdef inline bint _space(Py_UCS4 c):
    return c == 32 or c == 9 or c == 10 or c == 13 or c == 12 or c == 11


cdef inline bint _word(Py_UCS4 c):          # \w
    return c == 95 or Py_UNICODE_ISALNUM(c)


cdef inline bint _word_start(Py_UCS4 c):    # [^\W\d]
    return (c == 95 or Py_UNICODE_ISALNUM(c)) and not Py_UNICODE_ISDECIMAL(c)


cdef inline bint _punct(Py_UCS4 c):         # [{}():,.=@]
    return (c == 123 or c == 125 or c == 40 or c == 41 or c == 58 or c == 44 or c == 46 or c == 61
            or c == 64)


cdef inline Py_ssize_t _digits(int kind, void* data, Py_ssize_t i, Py_ssize_t end):
    while i < end and Py_UNICODE_ISDECIMAL(PyUnicode_READ(kind, data, i)):
        i += 1
    return i


cdef inline Py_ssize_t _names(int kind, void* data, Py_ssize_t i, Py_ssize_t end, bint* slash):
    """After the first character of a word: \\w*(?:/[^\\W\\d]\\w*)*+; `slash` set when a / is taken."""
    while i < end and _word(PyUnicode_READ(kind, data, i)):
        i += 1
    while i + 1 < end and PyUnicode_READ(kind, data, i) == 47 and _word_start(PyUnicode_READ(kind, data, i + 1)):
        slash[0] = True
        i += 2
        while i < end and _word(PyUnicode_READ(kind, data, i)):
            i += 1
    return i


cdef Py_ssize_t _number(int kind, void* data, Py_ssize_t i, Py_ssize_t end):
    """[+-]?(?:\\d+(?:\\.\\d*)?|\\.\\d+)(?:[eE][+-]?\\d+)? at i: its end, or -1."""
    cdef Py_UCS4 c = PyUnicode_READ(kind, data, i)
    cdef Py_ssize_t j, k
    if c == 43 or c == 45:
        i += 1
    j = _digits(kind, data, i, end)
    if j > i:
        if j < end and PyUnicode_READ(kind, data, j) == 46:
            j = _digits(kind, data, j + 1, end)
    elif i < end and PyUnicode_READ(kind, data, i) == 46:
        j = _digits(kind, data, i + 1, end)
        if j == i + 1:
            return -1
    else:
        return -1
    if j < end:
        c = PyUnicode_READ(kind, data, j)
        if c == 101 or c == 69:
            k = j + 1
            if k < end:
                c = PyUnicode_READ(kind, data, k)
                if c == 43 or c == 45:
                    k += 1
            if _digits(kind, data, k, end) > k:
                j = _digits(kind, data, k, end)
    return j


cdef int _scan(int kind, void* data, Py_ssize_t pos, Py_ssize_t end, Py_ssize_t* out_end, bint* slash):
    """The token class at `pos` (white space skipped already) and its end; K_NONE if none matches."""
    cdef Py_UCS4 c = PyUnicode_READ(kind, data, pos)
    cdef Py_UCS4 d = PyUnicode_READ(kind, data, pos + 1) if pos + 1 < end else 0
    cdef Py_ssize_t i
    if c == 35 or (c == 47 and d == 47):                                  # // or #
        i = pos + 1
        while i < end and PyUnicode_READ(kind, data, i) != 10:
            i += 1
        out_end[0] = i
        return K_LINE_COMMENT
    if c == 47 and d == 42:                                              # /* ... */
        i = pos + 2
        while i + 1 < end:
            if PyUnicode_READ(kind, data, i) == 42 and PyUnicode_READ(kind, data, i + 1) == 47:
                out_end[0] = i + 2
                return K_BLOCK_COMMENT
            i += 1
    if c == 34:                                                          # "..."
        i = pos + 1
        while i < end:
            c = PyUnicode_READ(kind, data, i)
            if c == 34:
                out_end[0] = i + 1
                return K_STRING
            if c == 10:
                break
            if c == 92:
                if i + 1 < end and PyUnicode_READ(kind, data, i + 1) != 10:
                    i += 2
                    continue
                break
            i += 1
        c = 34
    if c == 45 and d == 62:                                              # ->
        out_end[0] = pos + 2
        return K_ARROW
    i = pos + 1 if c == 126 else pos                                     # ~?/name(/name)*
    if i + 1 < end and PyUnicode_READ(kind, data, i) == 47 and _word_start(PyUnicode_READ(kind, data, i + 1)):
        out_end[0] = _names(kind, data, i + 2, end, slash)
        return K_ROS_NAME
    if c == 43 or c == 45 or c == 46 or Py_UNICODE_ISDECIMAL(c):
        i = _number(kind, data, pos, end)
        if i >= 0:
            out_end[0] = i
            return K_NUMBER
    if _word_start(c):
        slash[0] = False
        out_end[0] = _names(kind, data, pos + 1, end, slash)
        return K_WORD
    if _punct(c):
        out_end[0] = pos + 1
        return K_PUNCT
    return K_NONE


cdef inline object _first(object x, object span_type):
    """lexer's `_first`: where a child starts, or None."""
    cdef object span
    if type(x) is _Bare:
        return ((<_Bare>x).line, (<_Bare>x).col)
    if isinstance(x, Token):
        return (x.line or 1, x.column or 1)
    span = getattr(x, "span", None)
    if isinstance(span, span_type):
        return (span.line, span.col)
    if isinstance(x, (list, tuple)):
        for y in x:
            found = _first(y, span_type)
            if found is not None:
                return found
    return None


cdef inline object _last(object x, object span_type):
    """lexer's `_last`: where a child ends, or None."""
    cdef object span
    if type(x) is _Bare:
        return ((<_Bare>x).line, (<_Bare>x).col + ((<_Bare>x).end - (<_Bare>x).start))
    if isinstance(x, Token):
        return (x.end_line or x.line or 1, x.end_column or x.column or 1)
    span = getattr(x, "span", None)
    if isinstance(span, span_type):
        return (span.end_line, span.end_col)
    if isinstance(x, (list, tuple)):
        for y in reversed(x):
            found = _last(y, span_type)
            if found is not None:
                return found
    return None


cdef class FastDriver:
    """Parses text with the table Lark built for the grammar, calling the rules' methods of
    `target` (each named in `rules`) as `method(meta, children)`: `meta` the (line, column,
    end line, end column) of the children, `children` without the tokens whose terminal is not
    in `meaningful`. The interface of `lexer.Driver` (`parse`, `comments`)."""

    cdef int nstates, nsyms, nrules, start, end, end_term, name_term, ros_type_term, lpar_term, rpar_term
    cdef int string_term, number_term, ros_name_term
    cdef int* action                   # state * nsyms + symbol: 0 error, s + 1 shift to s, -(r + 1) reduce r
    cdef int* rule_len
    cdef int* rule_origin
    cdef char* meaningful
    cdef int max_nesting
    cdef list rule_plan                 # per rule: (to_include, trailing Nones, expand1, method, name, helper)
    cdef dict punct                     # one character -> terminal id
    cdef dict keywords                  # a word -> terminal id, where a keyword can stand
    cdef list term_names                # terminal id -> its name (interned)
    cdef object states, comment, too_deep, span_type, tree
    cdef public list comments

    def __init__(self, lark, target, rules, meaningful, named_words, int max_nesting, comment, too_deep, span_type):
        frontend = lark.parser
        lalr = frontend.parser.parser
        table = lalr.parse_table
        self.states = table.states
        self.comment, self.too_deep, self.span_type, self.max_nesting = comment, too_deep, span_type, max_nesting
        self.comments = []
        literals = {t.pattern.value: t.name for t in lark.terminals if isinstance(t.pattern, PatternStr)}
        lexed = {"$END", "NAME", "ROS_TYPE", "ROS_NAME", "STRING", "NUMBER", "ARROW"}   # every terminal it makes
        symbols = sorted({k for actions in table.states.values() for k in actions} | lexed | set(literals.values())
                         | set(named_words.values()))
        ids = {s: i for i, s in enumerate(symbols)}
        self.term_names = [s for s in symbols]
        self.nsyms = len(symbols)
        self.nstates = max(table.states) + 1
        rules_list = list(lalr.callbacks)
        rule_ids = {r: i for i, r in enumerate(rules_list)}
        self.nrules = len(rules_list)
        self.action = <int*>malloc(sizeof(int) * self.nstates * self.nsyms)
        self.rule_len = <int*>malloc(sizeof(int) * max(1, self.nrules))
        self.rule_origin = <int*>malloc(sizeof(int) * max(1, self.nrules))
        self.meaningful = <char*>malloc(self.nsyms)
        if not self.action or not self.rule_len or not self.rule_origin or not self.meaningful:
            raise MemoryError()
        cdef int i
        for i in range(self.nstates * self.nsyms):
            self.action[i] = 0
        for state, actions in table.states.items():
            for sym, (act, arg) in actions.items():
                self.action[state * self.nsyms + ids[sym]] = (arg + 1) if act is Shift else -(rule_ids[arg] + 1)
        for i in range(self.nsyms):
            self.meaningful[i] = symbols[i] in meaningful
        self.start, self.end = table.start_states["start"], table.end_states["start"]
        self.end_term = ids["$END"]
        self.name_term, self.ros_type_term, self.ros_name_term = ids["NAME"], ids["ROS_TYPE"], ids["ROS_NAME"]
        self.string_term, self.number_term = ids["STRING"], ids["NUMBER"]
        self.punct = {k: ids[v] for k, v in literals.items() if len(k) == 1}
        self.punct["->"] = ids["ARROW"]
        self.lpar_term = self.punct.get("(", -1)
        self.rpar_term = self.punct.get(")", -1)
        self.keywords = {k: ids[v] for k, v in {**dict(named_words), **literals}.items()}
        self.rule_plan = []
        self.tree = Tree
        for i, rule in enumerate(rules_list):
            self.rule_len[i] = len(rule.expansion)
            self.rule_origin[i] = ids[rule.origin.name]
            self.rule_plan.append(_plan(rule, target, rules, lark.options.maybe_placeholders))

    def __dealloc__(self):
        free(self.action)
        free(self.rule_len)
        free(self.rule_origin)
        free(self.meaningful)

    cdef object _token(self, str text, int term, Py_ssize_t start, Py_ssize_t end, Py_ssize_t line, Py_ssize_t col):
        """A Lark Token, as the Python driver makes it."""
        value = text[start:end]
        t = _str_new(Token, value)
        t.type = self.term_names[term]
        t.value = value
        t.start_pos = start
        t.line = line
        t.column = col
        t.end_line = line
        t.end_column = col + (end - start)
        t.end_pos = end
        return t

    cdef object _materialize(self, str text, object x):
        if type(x) is _Bare:
            b = <_Bare>x
            return self._token(text, b.term, b.start, b.end, b.line, b.col)
        return x

    def parse(self, str text):
        cdef int kind = PyUnicode_KIND(text)
        cdef void* data = PyUnicode_DATA(text)
        cdef Py_ssize_t pos = 0, end = len(text), start = 0, tok_end = 0, line = 1, line_start = 0, col = 0, i, n
        cdef Py_ssize_t cap = 256, top = 0, newlines = 0
        cdef int* stack = <int*>malloc(sizeof(int) * cap)
        cdef int depth = 0, cls, term, act, state, r, waiting = 0
        cdef bint slash = False, is_end
        cdef list values = []
        cdef object value, last = None          # the last token (a Token or a _Bare), for comments
        cdef _Bare bare
        if not stack:
            raise MemoryError()
        stack[0] = self.start
        try:
            while True:
                newlines = 0                    # white space
                while pos < end:
                    if PyUnicode_READ(kind, data, pos) == 10:
                        newlines += 1
                        line += 1
                        line_start = pos + 1
                    elif not _space(PyUnicode_READ(kind, data, pos)):
                        break
                    pos += 1
                if pos < end:
                    slash = False
                    cls = _scan(kind, data, pos, end, &tok_end, &slash)
                    if cls == K_NONE:
                        self._unexpected_character(text, pos, line, pos - line_start + 1, stack[top])
                    start, col = pos, pos - line_start + 1
                    pos = tok_end
                    if cls == K_LINE_COMMENT or cls == K_BLOCK_COMMENT:
                        self._comment(text, start, pos, line, col, newlines, last)
                        waiting += 1
                        if cls == K_BLOCK_COMMENT:
                            for i in range(start, pos):
                                if PyUnicode_READ(kind, data, i) == 10:
                                    line += 1
                                    line_start = i + 1
                        continue
                    term = self._terminal(text, cls, start, pos, slash, stack[top])
                    if term == self.lpar_term:
                        depth += 1
                        if depth > self.max_nesting:
                            raise self.too_deep(self._token(text, term, start, pos, line, col))
                    elif term == self.rpar_term:
                        depth -= 1
                    if self.meaningful[term]:
                        value = self._token(text, term, start, pos, line, col)
                    else:
                        bare = _Bare.__new__(_Bare)
                        bare.term, bare.start, bare.end, bare.line, bare.col = term, start, pos, line, col
                        value = bare
                    last = value
                    if waiting:
                        shown = (line, col, text[start:pos])
                        for c in self.comments[len(self.comments) - waiting:]:
                            c.next = shown
                        waiting = 0
                    is_end = False
                else:
                    term = self.end_term
                    is_end = True
                    value = None
                while True:
                    state = stack[top]
                    act = self.action[state * self.nsyms + term]
                    if act == 0:
                        self._unexpected_token(text, term, value, last, state)
                    if act > 0:
                        top += 1
                        if top >= cap:
                            cap *= 2
                            stack = <int*>realloc(stack, sizeof(int) * cap)
                            if not stack:
                                raise MemoryError()
                        stack[top] = act - 1
                        values.append(value)
                        break
                    r = -act - 1
                    n = self.rule_len[r]
                    result = self._reduce(text, r, values, n)
                    top -= n
                    state = self.action[stack[top] * self.nsyms + self.rule_origin[r]] - 1
                    top += 1
                    if top >= cap:
                        cap *= 2
                        stack = <int*>realloc(stack, sizeof(int) * cap)
                        if not stack:
                            raise MemoryError()
                    stack[top] = state
                    values.append(result)
                    if is_end and state == self.end:
                        return self._materialize(text, result)
        finally:
            free(stack)

    cdef int _terminal(self, str text, int cls, Py_ssize_t start, Py_ssize_t pos, bint slash, int state) except -2:
        cdef object found
        cdef int kw
        if cls == K_WORD:
            if slash:
                return self.ros_type_term
            found = self.keywords.get(text[start:pos])
            if found is not None:
                kw = found
                if self.action[state * self.nsyms + kw] != 0:
                    return kw
            if (self.action[state * self.nsyms + self.name_term] != 0
                    or self.action[state * self.nsyms + self.ros_type_term] == 0):
                return self.name_term
            return self.ros_type_term
        if cls == K_PUNCT or cls == K_ARROW:
            return self.punct[text[start:pos]]
        if cls == K_STRING:
            return self.string_term
        if cls == K_NUMBER:
            return self.number_term
        return self.ros_name_term

    cdef object _reduce(self, str text, int r, list values, Py_ssize_t n):
        cdef tuple plan = <tuple>self.rule_plan[r]
        cdef list raw, children
        cdef Py_ssize_t size = PyList_GET_SIZE(values)
        cdef object x
        if n:
            raw = PyList_GetSlice(values, size - n, size)
            del values[size - n:size]
        else:
            raw = []
        to_include, trailing, expand1, method, name, helper = plan
        if to_include is None:
            children = raw
        else:
            children = []
            for i, expand, nones in to_include:
                if nones:
                    children.extend([None] * nones)
                x = raw[i]
                if expand:
                    items = (<_Splice>x).items if type(x) is _Splice else x.children
                    if children:
                        children.extend(items)
                    else:               # left recursion (`x*`): the list grows in place, as Lark's does
                        children = items
                else:
                    children.append(x)
            if trailing:
                children.extend([None] * trailing)
        if expand1 and len(children) == 1:
            return children[0]
        if helper:
            splice = _Splice.__new__(_Splice)
            (<_Splice>splice).items = children
            return splice
        if method is None:
            return self.tree(name, [self._materialize(text, c) for c in children])
        if not children:
            return method(None, children)
        first = _first(children, self.span_type)
        last = _last(children, self.span_type)
        meta = None if first is None or last is None else (first[0], first[1], last[0], last[1])
        return method(meta, [c for c in children if type(c) is not _Bare])

    cdef _comment(self, str text, Py_ssize_t start, Py_ssize_t pos, Py_ssize_t line, Py_ssize_t col,
                  Py_ssize_t newlines, object last):
        """A comment as the Python driver records it."""
        previous = self._materialize(text, last) if last is not None else None
        self.comments.append(self.comment(text, text[start:pos], line, col, pos, newlines, previous, self.comments))

    cdef _unexpected_character(self, str text, Py_ssize_t at, Py_ssize_t line, Py_ssize_t col, int state):
        actions = self.states[state]
        raise UnexpectedCharacters(text, at, line, col, allowed={k for k in actions if k.isupper()})

    cdef _unexpected_token(self, str text, int term, object value, object last, int state):
        actions = self.states[state]
        if term == self.end_term:
            if last is not None:
                token = Token.new_borrow_pos("$END", "", self._materialize(text, last))
            else:
                token = Token("$END", "", 0, 1, 1)
        else:
            token = self._materialize(text, value)
        raise UnexpectedToken(token, {s for s in actions if s.isupper()})


def _plan(rule, target, rules, placeholders):
    """How a reduction by `rule` is shaped, as Lark's ParseTreeBuilder would (keep_all_tokens):
    (children to take: (index, inline it, Nones before it) or None for all as they are, Nones
    after, `?rule` with one child gives the child, the method or None, the rule's name, whether
    it is a `_helper` whose children its parent inlines)."""
    name = rule.alias or rule.options.template_source or rule.origin.name
    method = getattr(target, name) if name in rules else None
    empty = rule.options.empty_indices if placeholders else None
    expansion = rule.expansion
    if empty:
        s = "".join(str(int(b)) for b in empty)
        nones = [len(ones) for ones in s.split("0")]
    else:
        nones = [0] * (len(expansion) + 1)
    taken = []
    pending = 0
    for i, sym in enumerate(expansion):
        pending += nones[i]
        taken.append((i, (not sym.is_term) and sym.name.startswith("_"), pending))
        pending = 0
    pending += nones[len(expansion)]
    plain = not empty and not any(expand for _, expand, _ in taken)
    helper = method is None and rule.origin.name.startswith("_")
    return (None if plain else taken, pending, bool(rule.options.expand1 and not rule.alias), method, name, helper)
