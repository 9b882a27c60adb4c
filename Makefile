# Two targets do all set-up on a fresh machine: `make demo` and `make test`.
PYTHON ?= python3
VENV := .venv
BIN := $(VENV)/bin
STAMP := $(VENV)/.installed
# The ROS 2 wheels pull in lark-parser 0.12 (for rosidl code generation, not needed to run),
# which installs the same `lark` package as lark 1.x and its own stubs: it is removed, and lark
# installed again, so reconf and mypy see lark 1.x.
LARK := lark==1.3.1

.PHONY: demo test typecheck bench clean system-deps

# The editable install also compiles the lexer and LALR driver (reconf_dsl/_fastparse.pyx, through
# setup.py and Cython); where that cannot be built, the Python driver parses (docs/editor.md).
$(STAMP): pyproject.toml setup.py reconf_dsl/_fastparse.pyx
	$(PYTHON) -m venv $(VENV)
	$(BIN)/pip install -q --upgrade pip
	$(BIN)/pip install -q -e '.[test,ros]'
	$(BIN)/pip uninstall -q -y lark-parser
	$(BIN)/pip install -q --force-reinstall --no-deps '$(LARK)'
	touch $(STAMP)

demo: $(STAMP)
	$(BIN)/reconf check examples/chatter.arch
	$(BIN)/reconf check examples/chatter_slow.arch || echo "(exit $$?: unsafe, as expected for this variant)"

# The host lab's loss and partitions by packet drops use nftables (docs/hosts.md): installed with
# apt-get where this runs as root and apt is there; elsewhere the tests that need it skip, saying so.
system-deps:
	@if ! command -v nft >/dev/null 2>&1 && [ "$$(id -u)" = 0 ] && command -v apt-get >/dev/null 2>&1; then \
		echo "installing nftables (the host lab's packet loss)"; \
		DEBIAN_FRONTEND=noninteractive apt-get install -y -q nftables >/dev/null 2>&1 || \
		{ apt-get update -q >/dev/null 2>&1 && DEBIAN_FRONTEND=noninteractive apt-get install -y -q nftables >/dev/null; } || \
		echo "nftables could not be installed: the tests of packet loss will skip"; \
	fi

# The tests that need no live ROS 2 graph run in two processes (the machine's two cores). The
# live ones (marker `ros`, each in a ROS domain of its own) run one at a time, the FTM ones last
# (their monitors hold replies to 1.5 periods, which a saturated machine misses); the host lab's
# (tests/ros/test_live_hosts.py), then one half of the fault campaign and one README walkthrough
# (BESIDE_LAB, so the two streams take about as long), run beside the first of them, since the
# lab's DDS traffic stays in network namespaces of their own, and so does mypy. The two streams
# take their ROS domains from ranges apart (RECONF_LIVE_DOMAINS): BESIDE_LAB runs on the loopback
# too, and a domain both used at once would let one test's nodes be taken for another's.
# Their output is printed once each is done (build/test-*.log); each run prints its slowest tests.
HOSTS_TESTS := tests/ros/test_live_hosts.py
FTM_LIVE := tests/ros/test_live_ftm.py
BESIDE_LAB := tests/ros/test_live_fault_campaign.py::test_every_fault_is_recovered_and_every_report_is_true[4] \
	tests/ros/test_live_readme.py::test_the_readme_walkthrough_runs_on_a_live_graph[model-and-reality]
# The project's modules are compiled first: where PYTHONDONTWRITEBYTECODE is set (CI containers
# set it), every process the tests start, hundreds of them, would compile them again.
SOURCES := checker reconf_ros reconf_dsl codegen bench
test: $(STAMP) system-deps
	$(BIN)/python -m compileall -q $(SOURCES) > /dev/null
	$(BIN)/python -m pytest -n 2 -m "not ros" --durations=10
	@mkdir -p build
	@$(BIN)/python -m mypy > build/test-mypy.log 2>&1 & mypy=$$!; \
	RECONF_LIVE_DOMAINS=51-100 $(BIN)/python -m pytest -m ros --durations=10 $(HOSTS_TESTS) $(foreach t,$(BESIDE_LAB),"$(t)") > build/test-hosts.log 2>&1 & hosts=$$!; \
	RECONF_LIVE_DOMAINS=1-50 $(BIN)/python -m pytest -m ros --durations=10 $(addprefix --ignore=,$(HOSTS_TESTS) $(FTM_LIVE)) $(foreach t,$(BESIDE_LAB),--deselect="$(t)"); live=$$?; \
	wait $$hosts; hosts_rc=$$?; \
	$(BIN)/python -m pytest -m ros --durations=10 $(FTM_LIVE); ftm=$$?; \
	wait $$mypy; mypy_rc=$$?; \
	echo "== the host lab's live tests ($(HOSTS_TESTS)), then BESIDE_LAB:"; cat build/test-hosts.log; \
	echo "== mypy:"; cat build/test-mypy.log; \
	test $$live = 0 && test $$ftm = 0 && test $$hosts_rc = 0 && test $$mypy_rc = 0

bench: $(STAMP)
	$(BIN)/python -m bench.bench_check

clean:
	rm -rf $(VENV) build *.egg-info
