# Every install step lives here: `make test` and `make demo` work on a bare machine with Python 3.
PYTHON ?= python3
VENV ?= .venv
BIN := $(VENV)/bin
# torch is installed explicitly, before stable-baselines3, so that pip takes the CPU wheel
# instead of a multi-GB CUDA build. Override with e.g. `make TORCH_SPEC="torch==2.5.1" test`.
TORCH_SPEC ?= torch==2.13.0
PYTEST_ARGS ?=

.PHONY: lint check install install-train install-all test test-gym test-docs docs play-screenshot test-long demo baselines baselines-learned students student-ppo competence gait tune-gait bench mutants curricula curricula-300k clean

$(BIN)/python:
	$(PYTHON) -m venv $(VENV)
	$(BIN)/python -m pip install --quiet --upgrade pip

$(VENV)/.installed: setup.cfg pyproject.toml | $(BIN)/python
	$(BIN)/python -m pip install --quiet -e ".[dev]"
	touch $@

$(VENV)/.installed-train: $(VENV)/.installed
	$(BIN)/python -m pip install --quiet "$(TORCH_SPEC)"
	$(BIN)/python -m pip install --quiet -e ".[dev,train]"
	touch $@

# Everything the tests use: the train extra and the RL libraries of examples/ (RLlib, TorchRL,
# RL Zoo3). ray[rllib] pins its own gymnasium; `pip check` proves the result is consistent.
$(VENV)/.installed-all: $(VENV)/.installed-train
	$(BIN)/python -m pip install --quiet -e ".[dev,train,ray,torchrl,zoo,demos,play,docs]"
	$(BIN)/python -m pip check
	touch $@

# The browser test of `aaai play` drives Debian's Chromium through its chromedriver (as root on CI).
CHROMIUM_BINARIES := /usr/bin/chromium /usr/bin/chromedriver
$(CHROMIUM_BINARIES) &:
	DEBIAN_FRONTEND=noninteractive apt-get update -qq >/dev/null
	DEBIAN_FRONTEND=noninteractive apt-get install -y -qq --no-install-recommends chromium chromium-driver >/dev/null

install: $(VENV)/.installed

# Lint and format checks (ruff, configured in pyproject.toml); `ruff format .` fixes the format.
lint: install
	$(BIN)/python -m ruff check .
	$(BIN)/python -m ruff format --check .

# Lint, format and types: ruff, then mypy over all of aaai and cli ([tool.mypy] in pyproject.toml).
check: lint
	$(BIN)/python -m mypy

install-train: $(VENV)/.installed-train

install-all: $(VENV)/.installed-all

# The suite on both cores (pytest-xdist): each test file runs whole in one of two worker processes,
# so a file's shared fixtures are built once. The install (pip) and Chromium (apt) run side by side.
test:
	$(MAKE) --no-print-directory -j2 install-all $(CHROMIUM_BINARIES)
	$(MAKE) --no-print-directory check
	$(BIN)/python -m pytest -q -m "not long and not docs_commands" -n 2 --dist loadfile $(PYTEST_ARGS)
	NO_MKDOCS_2_WARNING=1 $(BIN)/python -m mkdocs build --strict --quiet

# The tests of the environment, the scoring and the model files (the committed models included) on
# the oldest and the newest Gymnasium setup.cfg allows, each in a venv of its own under .nox/
# (noxfile.py: the dev and train extras, no Ray). CI runs it after `make test`.
test-gym: install
	TORCH_SPEC="$(TORCH_SPEC)" $(BIN)/python -m nox -s gym

# The documentation site (docs/ + mkdocs.yml) into site/; a broken link or a page missing from the
# nav fails it. `$(BIN)/mkdocs serve` shows it at http://127.0.0.1:8000 while you edit.
docs: install-all
	NO_MKDOCS_2_WARNING=1 $(BIN)/python -m mkdocs build --strict

# The README's picture of the page (docs/play.png), taken by the browser test of `aaai play`.
play-screenshot: install-all $(CHROMIUM_BINARIES)
	AAAI_PLAY_SCREENSHOT=docs/play.png $(BIN)/python -m pytest -q tests/test_play.py -k browser

# The long checks (docs: Development, Long checks), about 35 minutes on 2 idle cores; CI runs them
# after make test. The 20 slowest tests are listed at the end.
# PostgreSQL's programs, for the long test of a study kept on a PostgreSQL server (tests/test_study_postgres.py).
POSTGRES_PROGRAMS := /usr/lib/postgresql
$(POSTGRES_PROGRAMS):
	DEBIAN_FRONTEND=noninteractive apt-get update -qq >/dev/null
	DEBIAN_FRONTEND=noninteractive apt-get install -y -qq --no-install-recommends postgresql >/dev/null

test-long: install-all $(POSTGRES_PROGRAMS)
	$(BIN)/python -m pytest -q -m long --durations=20 $(PYTEST_ARGS)

# Every command of the documentation, run page by page on a fresh copy (tests/test_docs_commands.py;
# the commands it skips or runs smaller are listed there with their reasons), about 20 minutes.
test-docs: install-all
	$(BIN)/python -m pytest -q -m docs_commands $(PYTEST_ARGS)

# The main job on the shipped default config: a short curriculum training run, then its
# reserved-seed scoreboard. DEMO_RUN is replaced on every `make demo`.
DEMO_RUN ?= runs/demo
demo: install-train
	rm -rf $(DEMO_RUN)
	$(BIN)/aaai train --curriculum --run $(DEMO_RUN)
	$(BIN)/aaai eval --seeds reserved --policy $(DEMO_RUN)
	@echo "aaai is installed in $(VENV): 'source $(BIN)/activate' puts it on your PATH (or call $(BIN)/aaai)"

# The baseline table (docs: Baselines; the README shows it): random actions, the reference controller and the demo's PPO
# policy on the reserved seeds of all 13 levels x 11 difficulties (10 seeds each); runs the demo
# first if its run is missing. Prints how long it took.
baselines: install-train
	test -f $(DEMO_RUN)/final/model.zip || $(MAKE) demo
	$(BIN)/aaai baselines --demo-run $(DEMO_RUN) --out baselines

# The learned rows of the baseline table (docs: Learned agents): the student of the reference
# (DAgger, configs/student.yaml) and PPO in gait mode with the paper's curriculum over every cell
# (configs/ppo_gait.yaml), each trained (or resumed) if its run is not finished, then scored on all
# 1,430 reserved episodes; the table and heatmap keep the other rows.
STUDENT_RUN ?= runs/student
PPO_GAIT_RUN ?= runs/ppo_gait
baselines-learned: install-all
	if [ ! -f $(STUDENT_RUN)/final/model.zip ]; then if [ -f $(STUDENT_RUN)/config.yaml ]; then \
	  $(BIN)/aaai train --resume $(STUDENT_RUN); else $(BIN)/aaai train --config configs/student.yaml --run $(STUDENT_RUN); fi; fi
	if [ ! -f $(PPO_GAIT_RUN)/final/model.zip ]; then if [ -f $(PPO_GAIT_RUN)/config.yaml ]; then \
	  $(BIN)/aaai train --resume $(PPO_GAIT_RUN); else $(BIN)/aaai train --config configs/ppo_gait.yaml --run $(PPO_GAIT_RUN); fi; fi
	$(BIN)/aaai baselines --student-run $(STUDENT_RUN) --ppo-gait-run $(PPO_GAIT_RUN) --only student,ppo_gait --out baselines
	$(MAKE) students

# The students of docs/learned-agents.md ("What each level measures"), NAME:CONFIG:TRAINING-SEED each:
# trained (or resumed) into runs/NAME if not finished, then scored on all 1,430 reserved episodes as
# the table's column NAME. STUDENTS="student_search:configs/student_search.yaml:0" makes one.
STUDENTS ?= student_s1:configs/student.yaml:1 student_food_memory:configs/student_food_memory.yaml:0 \
  student_food_memory_s1:configs/student_food_memory.yaml:1 \
  student_food_memory_r12:configs/student_food_memory_r12.yaml:0 \
  student_food_memory_r12_s1:configs/student_food_memory_r12_s1.yaml:1 student_search:configs/student_search.yaml:0 \
  student_search_lstm:configs/student_lstm_default.yaml:0 student_lstm:configs/student_lstm.yaml:0 \
  student_search_sweep:configs/student_search_sweep.yaml:0 student_search_sweep_s1:configs/student_search_sweep.yaml:1 \
  student_search_sweep_discrete:configs/student_search_sweep_discrete.yaml:0 \
  student_search_sweep_discrete_s1:configs/student_search_sweep_discrete.yaml:1 \
  student_search_lstm_discrete:configs/student_search_lstm_discrete.yaml:0 \
  student_search_lstm_discrete_s1:configs/student_search_lstm_discrete.yaml:1 \
  student_search_lstm_discrete_r12:configs/student_search_lstm_discrete_r12.yaml:0 \
  student_search_lstm_discrete_r12_s1:configs/student_search_lstm_discrete_r12.yaml:1 \
  student_search_lstm_thorough:configs/student_search_lstm_thorough.yaml:0 \
  student_search_lstm_thorough_s1:configs/student_search_lstm_thorough.yaml:1 \
  student_camera:configs/student_camera.yaml:0
students: install-all
	for entry in $(STUDENTS); do name=$${entry%%:*}; rest=$${entry#*:}; config=$${rest%%:*}; seed=$${rest#*:}; \
	  if [ ! -f runs/$$name/final/model.zip ]; then if [ -f runs/$$name/config.yaml ]; then \
	    $(BIN)/aaai train --resume runs/$$name || exit 1; \
	  else $(BIN)/aaai train --config $$config --seed $$seed --run runs/$$name || exit 1; fi; fi; \
	  $(BIN)/aaai baselines --learned $$name=runs/$$name --only $$name --out baselines || exit 1; done

# The student reinforced (docs: Training, Reinforcing the student): PPO from the committed student
# (baselines/models/student.zip) with configs/student_ppo.yaml, trained or resumed, then scored on all
# 1,430 reserved episodes (resumes with the same --out) and compared per level with baselines/student.csv.
STUDENT_PPO_RUN ?= runs/student_ppo
student-ppo: install-train
	if [ -f $(STUDENT_PPO_RUN)/config.yaml ]; then $(BIN)/aaai train --resume $(STUDENT_PPO_RUN); else \
	  $(BIN)/aaai train --init-from baselines/models/student.zip --config configs/student_ppo.yaml --run $(STUDENT_PPO_RUN); fi
	$(BIN)/aaai eval --policy $(STUDENT_PPO_RUN) --seeds reserved --out $(STUDENT_PPO_RUN)/scoreboard_reserved.csv
	$(BIN)/aaai compare baselines/student.csv $(STUDENT_PPO_RUN)/scoreboard_reserved.csv --out $(STUDENT_PPO_RUN)/comparison.md

# Time to competence (docs: Learned agents): PPO on L0 d0-2 in gait and in rotation mode, each
# checkpoint scored on the 30 reserved episodes; resumes where it stopped.
competence: install-train
	$(BIN)/aaai experiment competence --out experiments/competence

# The curricula experiment (docs: Training, Curricula): every sampler (paper, uniform, learnability, plr)
# trained on one budget, config and cells, 3 seeds each, scored on reserved and trained seeds; writes
# experiments/curricula/ (table.md, table.csv, curves.png, runs.csv, each run's CSVs). The committed
# results are this budget: 50,000 gait decisions per run, 5 seeds per cell scored (about 25 minutes
# on 2 cores). Re-running continues where it stopped. Its settings (PPO's, the camera's look) are
# pinned in configs/curricula.yaml, the command's default --config, not taken from configs/default.yaml:
# a change of a default then leaves the committed experiment continuable. CURRICULA_ARGS adds options, e.g.
# CURRICULA_ARGS="--steps 500000 -k 10 --out experiments/curricula-500k" for the larger budget.
CURRICULA_ARGS ?=
curricula: install-train
	$(BIN)/aaai experiment curricula --steps 50000 -k 5 --out experiments/curricula $(CURRICULA_ARGS)

# The larger curricula experiment, sized by its power analysis (experiments/curricula-300k/power.md):
# paper, uniform and plr, 9 seeds each, 300,000 decisions a run, one run at a time (seed by seed), each
# checkpoint scored on reserved seeds (learning curves). About 25 minutes a run on one core; continues.
curricula-300k: install-train
	nice -n 10 $(BIN)/aaai experiment curricula --config configs/curricula-300k.yaml --samplers paper,uniform,plr \
	  --seeds 0-8 --steps 300000 -k 10 --curve-seeds-per-cell 5 --jobs 1 --prune-checkpoints --out experiments/curricula-300k

# The gait: measure its speeds (docs: Environment, "The body"), or tune it again (CMA-ES, the tune extra).
gait: install
	$(BIN)/python -m aaai.tools.gait_tuning --measure

tune-gait: install
	$(BIN)/python -m pip install --quiet -e ".[dev,tune]"
	$(BIN)/python -m aaai.tools.gait_tuning --drive --write

bench: install
	$(BIN)/python -m pip install --quiet -e ".[dev,bench]"
	$(BIN)/aaai bench --out bench

# Mutation testing (mutmut 3, configured in pyproject.toml under [tool.mutmut]): mutates core modules
# in a copy, mutants/, runs the tests that cover each mutant and prints killed / total per module; a
# fresh run each time. On 2 cores six of the seven modules took about 65 minutes, so by default it
# mutates four (about 30 minutes); MUTANTS_MODULES="evaluation policies" (the scoring modules) and MUTANTS_MODULES=validate (about
# 30) are the rest, MUTANTS_MODULES=all runs everything, MUTANTS_MODULES="rewards seeds" any subset.
MUTANTS_MODULES ?= rewards curriculum sensors seeds
mutants: install-train
	$(BIN)/python -m pip install --quiet "mutmut>=3.8"
	rm -rf mutants
	$(BIN)/mutmut run $(if $(filter all,$(MUTANTS_MODULES)),,$(foreach m,$(MUTANTS_MODULES),"aaai.*.$(m).*"))
	@$(BIN)/mutmut results --all true | sed -nE 's/^ *aaai\.([a-z_]+)\.([a-z_]+)\.[^:]*: (.*)$$/\1\/\2 \3/p' | awk '\
	  $$2 == "not" { next } \
	  !($$1 in total) { order[++modules] = $$1 } \
	  { total[$$1]++; n++ } \
	  $$2 == "killed" { killed[$$1]++; k++ } $$2 == "survived" { s++ } $$2 == "no" { t++ } $$2 == "timeout" { o++ } \
	  END { for (i = 1; i <= modules; i++) { m = order[i]; \
	          printf "  aaai/%s.py: %d / %d killed (%.0f%%)\n", m, killed[m], total[m], 100 * killed[m] / total[m] }; \
	        if (n) printf "mutation score: %d / %d killed (%.1f%%); %d survived, %d in code no selected test runs, %d timed out\n", \
	          k, n, 100 * k / n, s, t, o }'

clean:
	rm -rf $(VENV) *.egg-info .pytest_cache site
