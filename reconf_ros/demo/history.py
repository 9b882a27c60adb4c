"""The demo client's whole history checked as a Jepsen checker checks one: every operation the
client invoked (a request, `sent`) and every completion it saw (a reply), against the server's
model (reconf_ros.demo.ftm: the state `s` becomes `step(s, x)`, and the reply is the new state).

The client invokes request i (x = i) in order, without waiting for earlier replies, and the
mechanism promises to apply each request once, in the client's order (the proxy's). Because
`step` is invertible, each reply names the state it was computed from, so the order in which the
server really applied the requests is read off the replies rather than searched for: from the
initial state, the request whose reply was computed from the current state comes next; where
none was, a request applied without a reply reaching the client (an unanswered one, or one
applied a second time) may bridge the gap, as Jepsen's indeterminate operations may. Then:

- `phantom`: a reply to a request never sent;
- `duplicated`: more than one reply to one request (`conflicting` when they differ);
- `applied_twice`: a request applied again after it was applied once;
- `reordered`: a request applied after a later one (the client's order broken: concurrent
  requests may be linearizable in either order, but the mechanism promises this one);
- `wrong`: a reply computed from a state no history of these requests reaches (a computation
  fault that got through, or a replica that had not followed);
- `lost`: invoked before `until` and never completed (indeterminate to Jepsen, a failure here:
  the mechanism promises every request an answer).

`linearizable` is true when nothing but `lost` is found (and the client's order is kept).

    python -m reconf_ros.demo.history client.jsonl              # exit 0: linearizable and nothing lost
    python -m reconf_ros.demo.history client.jsonl --more 100   # once 100 more requests are answered
Real time needs no check of its own here: every operation writes and returns the whole state,
so a reply reflecting a request invoked after it completed would name a state no history
reaches, and is `wrong`.
"""
from __future__ import annotations

import sys
import time
from typing import Any, Optional

from .ftm import MODULUS, read_log, step, wait_replies

__all__ = ["check_history", "ANOMALIES", "main"]

ANOMALIES = ("phantom", "duplicated", "conflicting", "applied_twice", "reordered", "wrong", "lost")
_INV31 = pow(31, -1, MODULUS)
_NEAR = 64          # how far (in request ids) a silent application is looked for


def _origin(result: int, x: int) -> int:
    """The state a reply of request x with value `result` was computed from."""
    return (result - x) * _INV31 % MODULUS


def _applied(answered: dict[int, int], invoked: set[int]) -> list[tuple[int, bool]]:
    """The order in which the server applied the requests, as the replies show it: (request,
    silently) pairs, `silently` for one applied without its reply showing it (an unanswered
    request, one applied again, or one whose reply was not its value)."""
    by_origin: dict[int, list[int]] = {}
    for i, value in answered.items():
        by_origin.setdefault(_origin(value, i), []).append(i)
    state, path, used = 0, [], set()
    while True:
        nxt = sorted(i for i in by_origin.get(state, []) if i not in used)
        if nxt:
            path.append((nxt[0], False))
            used.add(nxt[0])
            state = answered[nxt[0]]
            continue
        last = path[-1][0] if path else 0
        near = sorted(j for j in invoked if abs(j - last) <= _NEAR)
        bridge = next((j for j in near if any(i not in used for i in by_origin.get(step(state, j), []))), None)
        if bridge is None:
            return path
        path.append((bridge, True))
        state = step(state, bridge)


def check_history(log: dict[str, Any], until: float) -> dict[str, Any]:
    """The anomalies of a client's history (`reconf_ros.demo.ftm.read_log`), by kind (ANOMALIES),
    each a sorted list of request ids, and `linearizable`; `completed`: how many requests have a
    reply. Requests sent at or after `until` are not judged lost (they may be on their way)."""
    sent: dict[int, float] = log["sent"]
    replies: dict[int, list[dict[str, Any]]] = log["replies"]
    found: dict[str, set[int]] = {k: set() for k in ANOMALIES}
    answered: dict[int, int] = {}
    for i, reps in replies.items():
        if i not in sent:
            found["phantom"].add(i)
        if len(reps) > 1:
            found["duplicated"].add(i)
            if len({str(r.get("result")) for r in reps}) > 1:
                found["conflicting"].add(i)
        if isinstance(reps[0].get("result"), int):
            answered[i] = int(reps[0]["result"])
        else:
            found["wrong"].add(i)
    path = _applied(answered, set(sent))
    applied = {i for i, silently in path if not silently}
    found["wrong"] |= set(answered) - applied
    seen: set[int] = set()
    for i, silently in path:
        if i in seen:
            found["applied_twice"].add(i)
        if any(k > i for k in seen) and i not in seen:
            found["reordered"].add(i)
        seen.add(i)
    found["lost"] = {i for i, t in sent.items() if t < until and i not in replies}
    out: dict[str, Any] = {k: sorted(v) for k, v in found.items()}
    out["completed"] = len(replies)
    out["linearizable"] = not any(out[k] for k in ANOMALIES if k != "lost")
    return out


def main(argv: Optional[list[str]] = None) -> int:
    """Judge a client's log (its requests sent more than 2 s ago; with `--more N`, once N more are
    answered, those sent before the last one answered): print each anomaly found, exit 0 when the history is
    linearizable and nothing is lost, 1 otherwise (or when the N replies did not come within
    `--timeout` s), 2 for a bad command line."""
    import argparse
    ap = argparse.ArgumentParser(prog="python -m reconf_ros.demo.history",
                                 description="Judge a demo client's whole history (its log, JSON lines).")
    ap.add_argument("log", metavar="CLIENT_LOG")
    ap.add_argument("--more", type=int, default=0, metavar="N",
                    help="first wait until N more requests are answered than are now, then judge")
    ap.add_argument("--timeout", type=float, default=60.0, help="seconds --more waits at most (default 60)")
    args = ap.parse_args(sys.argv[1:] if argv is None else argv)
    if args.more > 0:
        began = time.time()
        if not wait_replies(args.log, args.more, args.timeout, after=began):
            print(f"{args.log}: fewer than {args.more} requests answered in {args.timeout:g} s")
            return 1
        print(f"{args.log}: {args.more} more requests answered in {time.time() - began:.2f} s")
        log = read_log(args.log)
        # the mechanism answers in the client's order: a request sent before the last one
        # answered and still unanswered is lost, however slow the replies
        until = max(log["sent"].get(i, 0.0) for i in log["replies"])
    else:
        log, until = read_log(args.log), time.time() - 2.0
    found = check_history(log, until=until)
    bad = {k: found[k] for k in ANOMALIES if found[k]}
    for kind, ids in bad.items():
        print(f"{kind}: {len(ids)} request{'s' if len(ids) != 1 else ''} ({', '.join(map(str, ids[:10]))}"
              f"{', ...' if len(ids) > 10 else ''})")
    verdict = "linearizable" if found["linearizable"] else "NOT linearizable"
    print(f"{args.log}: {found['completed']} requests answered; {verdict}"
          f"{', nothing lost' if not found['lost'] else ''}")
    return 0 if not bad else 1


if __name__ == "__main__":
    sys.exit(main())
