/*
 * reconf meta-model: the semantic model of event-driven systems
 * (docs/design.md#the-semantic-model), the six reconfiguration actions with their
 * pre/post-conditions (paper 001 §4.3), and the assertions that each action takes a valid
 * configuration to a valid one.
 *
 * Generated from codegen/templates/alloy/ by `python -m codegen.alloy --regenerate`;
 * edit the templates, not this file.
 *
 * Encoding notes (for speed): rates are ordered atoms (util/ordering), a check compares
 * exactly two configurations (Pre and Post), the current mode of a functionality is the
 * set `degraded` of its configuration, roles are one ternary relation, and the
 * satisfaction relation and the satisfied connectors and inputs of each configuration
 * are relations fixed by their definitions (this took the six checks at scope 5 from
 * minutes to seconds).
 *
 * Lines tagged "--@pre <action>.<name>" are precondition clauses; the mutation tests
 * delete them one at a time to show each is needed.
 */
module reconf

open util/ordering[Rate] as ro

-- Data predicates --------------------------------------------------------------------

sig MType {}
sig Rate {}
abstract sig Data {}
one sig Nothing extends Data {}
sig Msg extends Data {
  mtype: one MType,
  rate: lone Rate
}
fun rate_next: Rate -> Rate { ro/next }

-- The satisfaction relation, fixed by its definition (one relation instead of a circuit
-- per use).
one sig Sem {
  sat: Data -> Data
}
fact satisfaction {
  Sem.sat = {p, q: Msg | p.mtype = q.mtype and (no q.rate or (some p.rate and p.rate in q.rate.*rate_next))}
}

-- Architecture (static) --------------------------------------------------------------

sig Component {
  inputs: set Input,
  outputs: set Output,
  funcs: set Functionality
}
abstract sig Port {
  ptype: set MType  -- the message type it carries (one: typed_ports, the only reader)
}
sig Input extends Port {
  iasm: one Data
}
sig Output extends Port {}

sig Functionality {
  assoc_in: set Input,
  assoc_out: set Output,
  nasms: set Data,
  nguar: Output -> lone Data,
  dguar: Output -> lone Data
}

sig Connector {
  cguar: one Data
}
-- The `single` topics and the services: each takes at most one publisher (server).
one sig Kinds {
  singles: set Connector,
  services: set Connector
}
fun single: set Connector { Kinds.singles }
fun service: set Connector { Kinds.services }

one sig Env {
  guars: set Data
}
fun envg: set Data { Env.guars }

fact architecture {
  all p: Input | one inputs.p
  all p: Output | one outputs.p
  all f: Functionality | one funcs.f
  all c: Component | c.funcs.assoc_in in c.inputs and c.funcs.assoc_out in c.outputs
  -- a guarantee per associated output, in each mode
  all f: Functionality | f.nguar.Data = f.assoc_out and f.dguar.Data = f.assoc_out
}

-- A port's assumption and its guarantees are of its message type, or nothing (the DSL's
-- RC121 and its port declarations). Only the typing of attachments reads it, so it is the
-- hypothesis of KeepsTyped rather than a fact every check carries.
pred typed_ports {
  all p: Port | one p.ptype
  all i: Input | i.iasm in Msg implies i.iasm.mtype = i.ptype
  all f: Functionality, o: f.assoc_out | (o.(f.nguar) + o.(f.dguar)) & Msg in mtype.(o.ptype)
}

-- Rules on modes: (i) every functionality has both modes (by construction); (ii) the
-- degraded mode assumes nothing (it has no assumptions); (iii) whatever a degraded
-- guarantee satisfies, the normal guarantee of the same output satisfies too.
fact degraded_weaker {
  all f: Functionality, o: f.assoc_out, x: Data |
    satisfy[o.(f.dguar), x] implies satisfy[o.(f.nguar), x]
}

-- Configurations ---------------------------------------------------------------------

abstract sig System {
  comps: set Component,
  degraded: set Functionality,
  roles: Connector -> Port,
  csat: set Connector,  -- derived: the satisfied connectors
  isat: set Input,      -- derived: the satisfied inputs
  ivia: Connector -> Input  -- derived: the satisfying attachments
}
one sig Pre, Post extends System {}

fact derived {
  all s: System | s.csat = sat_conns_def[s] and s.isat = sat_inputs_def[s] and s.ivia = sat_roles_def[s]
}

-- Semantics (shared with instance modules) -------------------------------------------

-- p satisfies q: two messages of the same type, and q has no rate or p has a rate at
-- least q's. Nothing satisfies nothing, not even nothing: a degraded mode that publishes
-- nothing promises nothing. `(Sem.sat)` relates every such (p, q) (see satisfy_def).
pred satisfy[p, q: Data] {
  q in p.(Sem.sat)
}

-- The functionalities of the present components.
fun present_funcs[s: System]: set Functionality {
  (s.comps).funcs
}

-- The normal and the degraded guarantees of the functionalities fs, per output.
fun nguar_of[fs: set Functionality]: Output -> Data { fs.nguar }
fun dguar_of[fs: set Functionality]: Output -> Data { fs.dguar }

-- The guarantee on output o of f in f's current mode.
fun cur_guar[s: System, f: Functionality, o: Output]: lone Data {
  f in (s.degraded) implies o.(dguar_of[f]) else o.(nguar_of[f])
}

-- What each output guarantees now: the current guarantees of the present functionalities.
fun out_guar[s: System]: Output -> Data {
  dguar_of[present_funcs[s] & (s.degraded)]
  + nguar_of[present_funcs[s] - (s.degraded)]
}

-- The assumptions of f's current mode (the degraded mode assumes nothing).
fun cur_asms[s: System, f: Functionality]: set Data {
  f in (s.degraded) implies none else f.nasms
}

-- Connector k is satisfied by an attached output other than those in no_o: one of them
-- guarantees, in its functionality's current mode, something that satisfies k's
-- guarantee. Two equivalent encodings (the meta-model checks they agree): quantifiers,
-- faster in the meta-model's SAT problems, and a join, which keeps instance modules of
-- hundreds of components small.
pred conn_satisfied_no_out_q[s: System, k: Connector, no_o: set Output] {
  some f: present_funcs[s], o: f.assoc_out - no_o |
    o in k.(s.roles) and satisfy[cur_guar[s, f, o], k.cguar]
}

pred conn_satisfied_no_out_j[s: System, k: Connector, no_o: set Output] {
  k.cguar in ((k.(s.roles) - no_o).(out_guar[s])).(Sem.sat)
}

pred conn_satisfied_no_out[s: System, k: Connector, no_o: set Output] {
  conn_satisfied_no_out_q[s, k, no_o]
}

-- The satisfied connectors: some attached output of a present functionality guarantees,
-- in its current mode, something that satisfies the connector's guarantee.
fun sat_conns_q[s: System]: set Connector {
  {k: Connector | conn_satisfied_no_out_q[s, k, none]}
}

-- The satisfied inputs: attached to a satisfied connector whose guarantee satisfies the
-- input's assumption.
fun sat_inputs_q[s: System]: set Input {
  {i: Input | some k: (s.roles).i & (s.csat) | satisfy[k.cguar, i.iasm]}
}

-- The same two sets as joins (no quantifier: the solver folds them over constant data at
-- any size; the meta-model checks the encodings agree).
fun sat_conns_j[s: System]: set Connector {
  (cguar & (s.roles).(out_guar[s]).(Sem.sat)).Data
}

fun sat_inputs_j[s: System]: set Input {
  (iasm & (~((s.roles) & ((s.csat) -> Port))).cguar.(Sem.sat)).Data
}

fun sat_conns_def[s: System]: set Connector {
  sat_conns_q[s]
}

fun sat_inputs_def[s: System]: set Input {
  sat_inputs_q[s]
}

pred conn_satisfied[s: System, k: Connector] {
  k in (s.csat)
}

pred input_satisfied[s: System, i: Input] {
  i in (s.isat)
}

-- Assumption a of f holds: by an associated satisfied input whose assumption satisfies
-- a, or by an environment guarantee.
pred asm_holds[s: System, f: Functionality, a: Data] {
  (some i: f.assoc_in | satisfy[i.iasm, a] and input_satisfied[s, i])
  or
  (some g: envg | satisfy[g, a])
}

-- What a precondition asks of the readers an action may cut off: they stay safe without
-- the attachments no_r (Connector -> Input). An input keeps what its other attachments
-- give it: "without" is about attachments, not whole inputs (docs/soundness.md, "One
-- semantics").
-- The satisfying attachments: k -> i, i attached to k, k satisfied, and k's guarantee
-- satisfying i's assumption. An input is satisfied through these.
fun sat_roles_q[s: System]: Connector -> Input {
  {k: Connector, i: Input | k -> i in (s.roles) and k in (s.csat)
                            and satisfy[k.cguar, i.iasm]}
}

fun sat_roles_j[s: System]: Connector -> Input {
  ((s.roles) & ((s.csat) -> Input)) & cguar.(Sem.sat).~iasm
}

fun sat_roles_def[s: System]: Connector -> Input {
  sat_roles_q[s]
}

pred input_satisfied_no_role[s: System, i: Input, no_r: Connector -> Input] {
  some ((s.ivia) - no_r).i
}

pred asm_holds_no_role[s: System, f: Functionality, a: Data, no_r: Connector -> Input] {
  (some i: f.assoc_in | satisfy[i.iasm, a] and input_satisfied_no_role[s, i, no_r])
  or
  (some g: envg | satisfy[g, a])
}

-- The functionalities fs stay safe without the attachments no_r.
pred safe_no_role_q[s: System, fs: set Functionality, no_r: Connector -> Input] {
  all f: fs, a: cur_asms[s, f] | asm_holds_no_role[s, f, a, no_r]
}

pred safe_no_role_j[s: System, fs: set Functionality, no_r: Connector -> Input] {
  no failing_no_role[s, fs, no_r]
}

pred safe_no_role[s: System, fs: set Functionality, no_r: Connector -> Input] {
  safe_no_role_q[s, fs, no_r]
}

-- The satisfied inputs without the attachments no_r, as a join.
fun sat_inputs_no_role[s: System, no_r: Connector -> Input]: set Input {
  Connector.((s.ivia) - no_r)
}

-- What holds for each functionality when the inputs ins are its satisfied ones: f -> every
-- datum that an associated input of ins, by its assumption, or an environment guarantee
-- satisfies.
fun holds_with[ins: set Input]: Functionality -> Data {
  (assoc_in & (Functionality -> ins)).iasm.(Sem.sat) + Functionality -> envg.(Sem.sat)
}

-- The current assumptions of the functionalities fs that do not hold when ins are the
-- satisfied inputs.
fun failing_with[s: System, fs: set Functionality, ins: set Input]: Functionality -> Data {
  (nasms & ((fs - (s.degraded)) -> Data)) - holds_with[ins]
}

-- ... with the satisfied inputs of the configuration, or without the attachments no_r.
fun failing[s: System, fs: set Functionality]: Functionality -> Data {
  failing_with[s, fs, (s.isat)]
}

fun failing_no_role[s: System, fs: set Functionality, no_r: Connector -> Input]: Functionality -> Data {
  failing_with[s, fs, sat_inputs_no_role[s, no_r]]
}

-- The safety property: every assumption of every present functionality's current mode holds.
pred valid_q[s: System] {
  all f: present_funcs[s], a: cur_asms[s, f] | asm_holds[s, f, a]
}

pred valid_j[s: System] {
  no failing[s, present_funcs[s]]
}

pred valid[s: System] {
  valid_q[s]                  --@rule state.valid
}

-- The rules of a configuration besides validity (checker.semantic_model.rules, `state.*`), one
-- predicate each: a `single` topic has at most one publisher and a service one server;
-- every attachment is well typed and of a present component. The quantifiers range over
-- the few `single` topics and services only.
pred single_ok[s: System] {
  all k: single | lone k.(s.roles) & Output                       --@rule state.single
}
pred service_ok[s: System] {
  all k: service | lone k.(s.roles) & Output                      --@rule state.service
}
pred typed_ok[s: System] {
  (s.roles).ptype in cguar.mtype                                  --@rule state.typed
}
pred owned_ok[s: System] {
  Connector.(s.roles) in (s.comps).(inputs + outputs)  --@rule state.owned
}
pred well_formed[s: System] {
  single_ok[s] and service_ok[s] and typed_ok[s] and owned_ok[s]
}

-- Actions ----------------------------------------------------------------------------

-- The preconditions that quantify, in their two encodings (see above).

-- Detaching input p from k leaves its component safe without that attachment (p keeps
-- what its other attachments give it).
pred detach_input_safe_q[s: System, k: Connector, p: Input] {
  some c: s.comps & inputs.p | safe_no_role[s, c.funcs, k -> p]
}
pred detach_input_safe_j[s: System, k: Connector, p: Input] {
  some s.comps & inputs.p
  no failing_no_role[s, (s.comps & inputs.p).funcs, k -> p]
}

-- Every present reader of connector k is safe without its attachments to k.
pred detach_output_safe_q[s: System, k: Connector] {
  safe_no_role[s, (s.comps & inputs.(k.(s.roles))).funcs, k -> Input]
}
pred detach_output_safe_j[s: System, k: Connector] {
  no failing_no_role[s, (s.comps & inputs.(k.(s.roles))).funcs, k -> Input]
}

-- Output p, of a present functionality, guarantees in its current mode what k requires.
pred attach_output_ok_q[s: System, k: Connector, p: Port] {
  some f: present_funcs[s] | p in f.assoc_out and satisfy[cur_guar[s, f, p], k.cguar]
}
pred attach_output_ok_j[s: System, k: Connector, p: Port] {
  k.cguar in p.(out_guar[s]).(Sem.sat)
}

-- The connectors that degrading f leaves unsatisfied: attached to f's outputs, satisfied
-- by no other attached output, nor by f's degraded guarantees. Their present readers
-- must stay safe without their attachments to them; f itself is exempt, as its degraded
-- mode assumes nothing (else a functionality reading its own output could never degrade).
fun degrade_aff[s: System, f: Functionality]: set Connector {
  { k: (s.roles).(f.assoc_out) | not conn_satisfied_no_out[s, k, f.assoc_out]
      and no o: f.assoc_out | o in k.(s.roles) and satisfy[o.(dguar_of[f]), k.cguar] }
}
pred degrade_safe_q[s: System, f: Functionality] {
  let aff = degrade_aff[s, f] |
    safe_no_role[s, (s.comps & inputs.(aff.(s.roles))).funcs - f, aff -> Input]
}
pred degrade_safe_j[s: System, f: Functionality] {
  let aff = degrade_aff[s, f] |
    no failing_no_role[s, (s.comps & inputs.(aff.(s.roles))).funcs - f, aff -> Input]
}

-- Every assumption of f's normal mode holds.
pred upgrade_holds_q[s: System, f: Functionality] {
  all a: f.nasms | asm_holds[s, f, a]
}
pred upgrade_holds_j[s: System, f: Functionality] {
  f.nasms in (f.assoc_in & (s.isat)).iasm.(Sem.sat) + envg.(Sem.sat)
}

-- Remove an isolated component. Its functionalities count as degraded from then on:
-- every functionality of an absent component is degraded (assert AbsentDegraded), so
-- that a later create finds them degraded.
pred remove[s, s2: System, c: Component] {
  c in s.comps                                             --@pre remove.present
  no s.roles.(c.inputs + c.outputs)                        --@pre remove.isolated
  s2.comps = s.comps - c                                   --@post remove.effect
  s2.degraded = s.degraded + c.funcs                       --@post remove.effect
  s2.roles = s.roles       --@post remove.effect
}

-- Create a component with all its functionalities degraded (they are: it was absent).
pred create[s, s2: System, c: Component] {
  c not in s.comps                                         --@pre create.absent
  c.funcs in s.degraded                                    --@pre create.degraded
  s2.comps = s.comps + c                                   --@post create.effect
  s2.degraded = s.degraded                                 --@post create.effect
  s2.roles = s.roles       --@post create.effect
}

-- Detach port p of a present component from connector k.
pred detach[s, s2: System, k: Connector, p: Port] {
  p in k.(s.roles)                                         --@pre detach.attached
  p in s.comps.(inputs + outputs)                          --@pre detach.present
  p in Input implies detach_input_safe_q[s, k, p]         --@pre detach.input
  (p in Output and not conn_satisfied_no_out[s, k, p]) implies detach_output_safe_q[s, k]  --@pre detach.output
  s2.comps = s.comps                                       --@post detach.effect
  s2.degraded = s.degraded                                 --@post detach.effect
  s2.roles = s.roles - k -> p --@post detach.effect
}

-- Attach port p of a present component to connector k; a `single` topic and a service take
-- one publisher (server).
pred attach[s, s2: System, k: Connector, p: Port] {
  p in s.comps.(inputs + outputs)                          --@pre attach.present
  p not in k.(s.roles)                                     --@pre attach.detached
  p in Output implies attach_output_ok_q[s, k, p]      --@pre attach.output
  p in Input implies satisfy[k.cguar, p.iasm]              --@pre attach.input
  (p in Output and k in single) implies no k.(s.roles) & Output   --@pre attach.single
  (p in Output and k in service) implies no k.(s.roles) & Output  --@pre attach.service
  s2.comps = s.comps                                       --@post attach.effect
  s2.degraded = s.degraded                                 --@post attach.effect
  s2.roles = s.roles + k -> p --@post attach.effect
}

-- Degrade functionality f of a present component.
pred degrade[s, s2: System, f: Functionality] {
  f in present_funcs[s]                                    --@pre degrade.present
  f not in s.degraded                                      --@pre degrade.normal
  degrade_safe_q[s, f]                                --@pre degrade.safe
  s2.comps = s.comps                                       --@post degrade.effect
  s2.degraded = s.degraded + f                             --@post degrade.effect
  s2.roles = s.roles       --@post degrade.effect
}

-- Upgrade functionality f of a present component to its normal mode, breaking no connector
-- (rule iii on modes, a fact of the meta-model, makes that clause hold there; an instance
-- module checks it).
pred upgrade[s, s2: System, f: Functionality] {
  f in present_funcs[s]                                    --@pre upgrade.present
  f in s.degraded                                          --@pre upgrade.degraded
  upgrade_holds_q[s, f]                               --@pre upgrade.assumptions
  (s.csat) in (s2.csat)            --@pre upgrade.connectors
  s2.comps = s.comps                                       --@post upgrade.effect
  s2.degraded = s.degraded - f                             --@post upgrade.effect
  s2.roles = s.roles       --@post upgrade.effect
}

-- Attaching only adds satisfaction, so SafeAttach holds whatever attach requires; its
-- preconditions serve well-typed connections, which this assertion checks.
pred well_typed[s: System, k: Connector, p: Port] {
  p in Output implies (some f: present_funcs[s] | p in f.assoc_out and satisfy[cur_guar[s, f, p], k.cguar])
  p in Input implies satisfy[k.cguar, p.iasm]
}

-- One action of any kind takes s to s2.
pred step[s, s2: System] {
  (some c: Component | remove[s, s2, c] or create[s, s2, c])
  or (some k: Connector, p: Port | detach[s, s2, k, p] or attach[s, s2, k, p])
  or (some f: Functionality | degrade[s, s2, f] or upgrade[s, s2, f])
}

-- Safety of the actions --------------------------------------------------------------

assert SafeRemove  { all c: Component | valid[Pre] and remove[Pre, Post, c] implies valid[Post] }
assert SafeCreate  { all c: Component | valid[Pre] and create[Pre, Post, c] implies valid[Post] }
assert SafeDetach  { all k: Connector, p: Port | valid[Pre] and detach[Pre, Post, k, p] implies valid[Post] }
assert SafeAttach  { all k: Connector, p: Port | valid[Pre] and attach[Pre, Post, k, p] implies valid[Post] }
assert SafeDegrade { all f: Functionality | valid[Pre] and degrade[Pre, Post, f] implies valid[Post] }
assert SafeUpgrade { all f: Functionality | valid[Pre] and upgrade[Pre, Post, f] implies valid[Post] }
-- Absent components have every functionality degraded, and each action keeps it so:
-- this is how the configurations of the Python engine (which record no mode for an
-- absent component) are read in Alloy.
pred absent_degraded[s: System] { (Component - s.comps).funcs in s.degraded }
assert AbsentDegraded { absent_degraded[Pre] and step[Pre, Post] implies absent_degraded[Post] }
-- The six actions keep the rules of a configuration besides validity (checker.semantic_model.rules):
-- one publisher on a `single` topic, one server on a service, attachments well typed and of
-- present components.
assert KeepsSingle    { single_ok[Pre] and step[Pre, Post] implies single_ok[Post] }
assert KeepsOneServer { service_ok[Pre] and step[Pre, Post] implies service_ok[Post] }
assert KeepsTyped     { typed_ports and typed_ok[Pre] and step[Pre, Post] implies typed_ok[Post] }
assert KeepsOwned     { owned_ok[Pre] and step[Pre, Post] implies owned_ok[Post] }
assert AttachWellTyped { all k: Connector, p: Port | attach[Pre, Post, k, p] implies well_typed[Post, k, p] }
-- The two encodings of connector satisfaction in the shared semantics agree.
assert ConnectorEncodingsAgree {
  all k: Connector, no_o: set Output |
    conn_satisfied_no_out_q[Pre, k, no_o] iff conn_satisfied_no_out_j[Pre, k, no_o]
}

-- The joins that instance and plan modules use for satisfaction, the satisfied connectors and inputs,
-- validity and safety without inputs agree with the quantified definitions.
assert SatEncodingsAgree { Sem.sat = mtype.~mtype & (Msg -> (Msg - rate.Rate) + rate.~rate + rate.~(rate.^rate_next)) }
-- (with ConnectorEncodingsAgree, sat_conns_j = sat_conns_q)
assert ConnectorsEncodingsAgree { sat_conns_j[Pre] = {k: Connector | conn_satisfied_no_out_j[Pre, k, none]} }
assert InputsEncodingsAgree { sat_inputs_q[Pre] = sat_inputs_j[Pre] }
assert RolesEncodingsAgree { sat_roles_q[Pre] = sat_roles_j[Pre] }
assert ValidEncodingsAgree { valid_q[Pre] iff valid_j[Pre] }
assert SafetyEncodingsAgree {
  all fs: set Functionality, no_r: Connector -> Input |
    safe_no_role_q[Pre, fs, no_r] iff safe_no_role_j[Pre, fs, no_r]
}

-- The two encodings of the actions' preconditions that quantify agree: plan modules use the
-- joins, and the Safe* assertions above are proved over the quantifiers. (One assertion
-- each: their conjunction is one SAT problem that takes the solver a minute at scope 5.)
assert DetachInputEncodingsAgree {
  all k: Connector, p: Input | detach_input_safe_q[Pre, k, p] iff detach_input_safe_j[Pre, k, p]
}
assert DetachOutputEncodingsAgree { all k: Connector | detach_output_safe_q[Pre, k] iff detach_output_safe_j[Pre, k] }
assert AttachOutputEncodingsAgree {
  all k: Connector, p: Port | attach_output_ok_q[Pre, k, p] iff attach_output_ok_j[Pre, k, p]
}
assert DegradeEncodingsAgree { all f: Functionality | degrade_safe_q[Pre, f] iff degrade_safe_j[Pre, f] }
assert UpgradeEncodingsAgree { all f: Functionality | upgrade_holds_q[Pre, f] iff upgrade_holds_j[Pre, f] }

-- The satisfaction rule itself. The Safe assertions hold for any relation `sat`, so they say
-- nothing about this one; these pin it: nothing satisfies nothing, the type must match, a
-- rate is needed when one is asked for, and a rate satisfies exactly the rates up to it.
assert SatisfactionRule {
  no Nothing.(Sem.sat) and no (Sem.sat).Nothing
  all p, q: Msg {
    p.mtype != q.mtype implies not satisfy[p, q]
    p.mtype = q.mtype and no q.rate implies satisfy[p, q]
    p.mtype = q.mtype and some q.rate implies
      (satisfy[p, q] iff (some p.rate and ro/gte[p.rate, q.rate]))
  }
}

check SafeRemove  for 5 expect 0
check SafeCreate  for 5 expect 0
check SafeDetach  for 5 expect 0
check SafeAttach  for 5 expect 0
check SafeDegrade for 5 expect 0
check SafeUpgrade for 5 expect 0
check AbsentDegraded for 5 expect 0
check KeepsSingle for 5 expect 0
check KeepsOneServer for 5 expect 0
check KeepsTyped for 5 expect 0
check KeepsOwned for 5 expect 0
check AttachWellTyped for 5 expect 0
check ConnectorEncodingsAgree for 5 expect 0
check SatEncodingsAgree for 5 expect 0
check ConnectorsEncodingsAgree for 5 expect 0
check InputsEncodingsAgree for 5 expect 0
check RolesEncodingsAgree for 5 expect 0
check ValidEncodingsAgree for 5 expect 0
check SafetyEncodingsAgree for 5 expect 0
check DetachInputEncodingsAgree for 5 expect 0
check DetachOutputEncodingsAgree for 5 expect 0
check AttachOutputEncodingsAgree for 5 expect 0
check DegradeEncodingsAgree for 5 expect 0
check UpgradeEncodingsAgree for 5 expect 0
check SatisfactionRule for 5 expect 0

-- Each action's preconditions can hold between two valid configurations.
run Remove  { some c: Component | valid[Pre] and remove[Pre, Post, c] and valid[Post] } for 3 expect 1
run Create  { some c: Component | valid[Pre] and create[Pre, Post, c] and valid[Post] } for 3 expect 1
run Detach  { some k: Connector, p: Port | valid[Pre] and detach[Pre, Post, k, p] and valid[Post] } for 3 expect 1
run Attach  { some k: Connector, p: Port | valid[Pre] and attach[Pre, Post, k, p] and valid[Post] } for 3 expect 1
run Degrade { some f: Functionality | valid[Pre] and degrade[Pre, Post, f] and valid[Post] } for 3 expect 1
run Upgrade { some f: Functionality | valid[Pre] and upgrade[Pre, Post, f] and valid[Post] } for 3 expect 1

-- Non-vacuity: the shapes users write appear in a valid step. A fact that empties part of
-- the instance space (as "nothing satisfies nothing" once did for every silent degraded
-- mode) would leave the checks above passing; it fails one of these runs instead.

-- A degraded mode that publishes nothing, while the normal mode publishes a message.
run SilentDegraded {
  some f: Functionality, o: f.assoc_out |
    o.(f.dguar) = Nothing and o.(f.nguar) in Msg and valid[Pre] and degrade[Pre, Post, f] and valid[Post]
} for 3 expect 1
-- The paper's talker and listener: the talker assumes nothing and publishes a message it
-- does not publish degraded; the listener, normal, assumes it through the connector alone.
run TalkerListener {
  no envg
  some disj t, l: Component, ft: t.funcs, fl: l.funcs, o: ft.assoc_out, i: fl.assoc_in, k: Connector {
    no ft.nasms and some fl.nasms and o.(ft.dguar) = Nothing and o.(ft.nguar) in Msg
    k -> o + k -> i in Pre.roles and Pre.comps = t + l and no (ft + fl) & Pre.degraded
    valid[Pre]
  }
} for 3 expect 1
-- A connector that asks for no rate stays satisfied when its publisher degrades to the
-- type without the rate, and is left unsatisfied when it degrades to nothing.
run RatelessConnectorKept {
  some f: Functionality, k: Connector |
    k.cguar in Msg and no k.cguar.rate and k in Pre.csat & Post.csat and some k.(Pre.roles) & f.assoc_out
    and no (k.(Pre.roles) & Output) - f.assoc_out and valid[Pre] and degrade[Pre, Post, f] and valid[Post]
} for 3 expect 1
run RatelessConnectorBroken {
  some f: Functionality, k: Connector |
    k.cguar in Msg and no k.cguar.rate and k in Pre.csat - Post.csat
    and valid[Pre] and degrade[Pre, Post, f] and valid[Post]
} for 3 expect 1
-- Two publishers on one connector: either may leave while the other keeps it satisfied.
run RedundantPublishers {
  some k: Connector, disj o1, o2: Output |
    k -> o1 + k -> o2 in Pre.roles and outputs.o1 != outputs.o2 and valid[Pre]
    and detach[Pre, Post, k, o1] and k in Post.csat and valid[Post]
} for 3 expect 1
-- An input on two connectors, the only source of a normal assumption: it may leave one
-- connector while the other still satisfies it.
run PortOnTwoConnectors {
  no envg
  some i: Input, disj k1, k2: Connector, f: Functionality |
    k1 -> i + k2 -> i in Pre.roles and i in f.assoc_in and f in present_funcs[Pre] - Pre.degraded
    and one f.assoc_in and some f.nasms and valid[Pre] and detach[Pre, Post, k1, i] and valid[Post]
} for 3 expect 1
-- A `single` topic gains its publisher, and a service its server, in valid, well-formed
-- steps; and the topic or service that has one refuses another.
run SingleTopicPublisher {
  some k: single - service, p: Output | some Pre.comps.funcs.nasms and well_formed[Pre] and valid[Pre]
    and attach[Pre, Post, k, p] and valid[Post] and well_formed[Post] and some k.(Post.roles) & Input
} for 3 expect 1
run ServiceServer {
  some k: service - single, p: Output | well_formed[Pre] and valid[Pre]
    and attach[Pre, Post, k, p] and valid[Post] and well_formed[Post] and some k.(Post.roles) & Input
} for 3 expect 1
run SecondPublisherRefused {
  some k: single + service, p: Output - k.(Pre.roles) | well_formed[Pre] and valid[Pre]
    and some k.(Pre.roles) & Output and attach_output_ok_q[Pre, k, p] and p in Pre.comps.outputs
    and Post.comps = Pre.comps and Post.degraded = Pre.degraded and Post.roles = Pre.roles + k -> p
    and not attach[Pre, Post, k, p]
} for 3 expect 1

-- Restoring validity (docs/soundness.md#restoring-validity) ----------------------------
-- A recovery starts from an observed configuration that need not be valid and first degrades
-- what fails. Degrading a present functionality f in its normal mode, one of whose assumptions
-- fails (Pre need not be valid):
pred recover_degrade[s, s2: System, f: Functionality] {
  f in present_funcs[s] - s.degraded
  some failing[s, f]
  s2.comps = s.comps
  s2.degraded = s.degraded + f
  s2.roles = s.roles
}
-- The functionalities of the components that read a connector an output of f is attached to.
fun readers_of[s: System, f: Functionality]: set Functionality {
  inputs.(((s.roles).(f.assoc_out)).(s.roles) & Input).funcs
}
-- ... makes no assumption fail that degrading its own functionality cannot mend: what fails
-- after is of a present functionality other than f in its normal mode (degraded, it assumes
-- nothing), that failed before or reads what f published on.
assert RecoverDegrade {
  all f: Functionality | recover_degrade[Pre, Post, f] implies
    failing[Post, present_funcs[Post]].Data in
      (present_funcs[Post] - Post.degraded - f) & (failing[Pre, present_funcs[Pre]].Data + readers_of[Pre, f])
}
-- Degrading more mends nothing else: with the same components and attachments and one more
-- functionality degraded, what fails of a functionality still normal still fails. By induction
-- on the functionalities added one at a time (failing[s, fs] is per functionality, so it may be
-- cut down to those still normal at the end), the same holds for any superset of degraded,
-- which z3 proves as such for every size (checker/semantic_model/unbounded.py). So the recovery's
-- degrades are needed by every valid configuration reached by degrading alone, and in any
-- order every state fails only on what a later one of them degrades.
assert RecoverMonotone {
  all f: Functionality |
    (Pre.comps = Post.comps and Pre.roles = Post.roles and Post.degraded = Pre.degraded + f) implies
      failing[Pre, present_funcs[Pre] - Post.degraded] in failing[Post, present_funcs[Post]]
}
check RecoverDegrade for 5 expect 0
check RecoverMonotone for 5 expect 0
-- Not vacuous: a degrade of a failing functionality can make a reader of its output fail.
run RecoverBreaksAReader {
  some f: Functionality | recover_degrade[Pre, Post, f] and
    some (failing[Post, present_funcs[Post]].Data - failing[Pre, present_funcs[Pre]].Data)
} for 3 expect 1
