/*
 * reconf FTM rules (docs/ftm.md#the-library, paper 000 Table I): what each fault-tolerance
 * mechanism tolerates, what it needs of the application, and what resources it takes; when a
 * composition is well formed and when it is valid for a component's (F, A, R).
 *
 * A composition is a set of mechanisms: its nesting order is fixed by layer (SEC outside a
 * duplex, a duplex outside TR), so the set determines it; `wellNested` judges the order a
 * component's FTM is written in, `enoughHosts` whether a duplex has two hosts. Checked in Python by
 * checker/ftm/select.py; instance modules (checker/ftm/alloy_rules.py) `open ftm` and ask
 * for the valid compositions of concrete components; the two must agree.
 *
 * Fixed data are functions (constants), not fields constrained by facts.
 */
module ftm

abstract sig Fault {}
one sig Crash, Transient, PermanentValue, Omission, Intrusion extends Fault {}

abstract sig AppChar {}
one sig Deterministic, StateAccess extends AppChar {}

abstract sig Level {}
one sig Nil, Low, Medium, High extends Level {}
-- a -> b when a is at most b
fun atMost: Level -> Level {
  Nil -> (Nil + Low + Medium + High) + Low -> (Low + Medium + High) + Medium -> (Medium + High) + High -> High
}

abstract sig Layer {}
one sig SecLayer, DupLayer, TrLayer extends Layer {}

abstract sig Mech {}
one sig PBR, LFR, AD, TR, SEC extends Mech {}

-- Table I (with A&D's duplex read as leader/follower, SEC as tolerating intrusions)
fun layer: Mech -> Layer { (PBR + LFR + AD) -> DupLayer + TR -> TrLayer + SEC -> SecLayer }
fun covers: Mech -> Fault {
  (PBR + LFR) -> Crash + AD -> (Crash + Transient + PermanentValue) + TR -> Transient + SEC -> Intrusion
}
fun needs: Mech -> AppChar {
  PBR -> StateAccess + (LFR + AD) -> Deterministic + TR -> (Deterministic + StateAccess)
}
fun bandwidth: Mech -> Level { PBR -> High + (LFR + AD) -> Low + (TR + SEC) -> Nil }
fun cpus: Mech -> Int { (PBR + LFR + AD) -> 2 + (TR + SEC) -> 1 }

-- One mechanism per layer at most, and at least one mechanism.
pred wellFormed[m: set Mech] {
  some m
  all l: Layer | lone m & layer.l
}

-- m is valid for faults f, application a, bandwidth bw and n CPUs.
pred validFor[m: set Mech, f: set Fault, a: set AppChar, bw: Level, n: Int] {
  wellFormed[m]
  f in m.covers
  m.needs in a
  all x: m | x.bandwidth -> bw in atMost
  all x: m | x.cpus <= n
}

-- The layer each layer may be written around: SEC around a duplex or TR, a duplex around TR.
fun outside: Layer -> Layer { SecLayer -> (DupLayer + TrLayer) + DupLayer -> TrLayer }

-- A written composition (x -> y: x is written directly around y, as in PBR(TR)) nests each
-- mechanism in a layer strictly inside the one around it (RC401).
pred wellNested[around: Mech -> Mech] {
  all x, y: Mech | x -> y in around implies x.layer -> y.layer in outside
}

-- A duplex replicates the server on two distinct hosts (RC406, a warning).
pred enoughHosts[m: set Mech, hosts: Int] {
  some m & (PBR + LFR + AD) implies hosts >= 2
}

-- Properties of the rules, checked over arbitrary profiles and compositions.
sig Probe {
  mechs: set Mech,
  pf: set Fault,
  pa: set AppChar,
  pbw: one Level,
  pn: one Int
}

pred valid[p: Probe] { validFor[p.mechs, p.pf, p.pa, p.pbw, p.pn] }

assert ValidCoversFaults { all p: Probe | valid[p] implies p.pf in p.mechs.covers }
assert OneDuplexAtMost { all p: Probe | valid[p] implies lone p.mechs & (PBR + LFR + AD) }
assert LFRNeedsDeterminism { all p: Probe | LFR in p.mechs and Deterministic not in p.pa implies not valid[p] }
assert PBRNeedsStateAccess { all p: Probe | PBR in p.mechs and StateAccess not in p.pa implies not valid[p] }
assert PBRNeedsHighBandwidth { all p: Probe | PBR in p.mechs and p.pbw != High implies not valid[p] }
assert OmissionUntolerated { all p: Probe | Omission in p.pf implies not valid[p] }
assert DuplexNeedsTwoCPUs { all p: Probe | some p.mechs & (PBR + LFR + AD) and p.pn < 2 implies not valid[p] }
-- Dropping a fault from F never invalidates a valid composition.
assert FewerFaultsStayValid {
  all p, q: Probe | valid[p] and q.mechs = p.mechs and q.pf in p.pf and q.pa = p.pa and q.pbw = p.pbw
    and q.pn = p.pn implies valid[q]
}

-- A written order (one chain: each mechanism directly inside at most one other, one
-- outermost) that nests well names one mechanism per layer.
assert WellNestedIsOnePerLayer {
  all around: Mech -> Mech |
    ((all x: Mech | lone x.around and lone around.x) and no iden & ^around
      and lone around.Mech - Mech.around and wellNested[around]) implies
      (all x: Mech.around + around.Mech | one (Mech.around + around.Mech) & layer.(x.layer))
}

check WellNestedIsOnePerLayer for 3 but 4 Int expect 0
check ValidCoversFaults for 3 but 4 Int expect 0
check OneDuplexAtMost for 3 but 4 Int expect 0
check LFRNeedsDeterminism for 3 but 4 Int expect 0
check PBRNeedsStateAccess for 3 but 4 Int expect 0
check PBRNeedsHighBandwidth for 3 but 4 Int expect 0
check OmissionUntolerated for 3 but 4 Int expect 0
check DuplexNeedsTwoCPUs for 3 but 4 Int expect 0
check FewerFaultsStayValid for 3 but 4 Int expect 0
-- The paper's composition can be valid: SEC(PBR(TR)) against crash, transient and intrusion.
run SecPbrTr { some p: Probe | valid[p] and p.mechs = SEC + PBR + TR and p.pf = Crash + Transient + Intrusion }
  for 3 but 4 Int expect 1
