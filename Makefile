# Every target bootstraps .venv from the project's own files on first use.
PY      ?= python3
VENV    := .venv
VPY     := $(VENV)/bin/python
STAMP   := $(VENV)/.installed
BENCH   := .venv-bench
BSTAMP  := $(BENCH)/.installed
TRAIN   := .venv-train
MOTV    := .venv-mot
MSTAMP  := $(MOTV)/.installed
TSTAMP  := $(TRAIN)/.installed
PIP_FLAGS ?= --disable-pip-version-check -q

export ROS_AUTOMATIC_DISCOVERY_RANGE ?= LOCALHOST
export PYTHONDONTWRITEBYTECODE = 1

.PHONY: venv test lint demo demo-sweep bench bench-venv mot-venv train-venv regress train clean

venv: $(STAMP)

$(STAMP): requirements.txt requirements-dev.txt setup.py setup.cfg package.xml
	test -x $(VPY) || $(PY) -m venv $(VENV)
	$(VPY) -m pip install $(PIP_FLAGS) --upgrade pip
	$(VPY) -m pip install $(PIP_FLAGS) -r requirements-dev.txt
	$(VPY) -m pip install $(PIP_FLAGS) --no-deps -e .
	touch $@

bench-venv: $(BSTAMP)

$(BSTAMP): requirements-bench.txt
	test -x $(BENCH)/bin/python || $(PY) -m venv $(BENCH)
	$(BENCH)/bin/python -m pip install $(PIP_FLAGS) -r requirements-bench.txt
	touch $@

# MOT peers (SORT, ByteTrack, OC-SORT of `trackers`) for benchmarks/mot_eval.py: own venv, --no-deps with
# the full pinned set of requirements-mot.txt (its opencv-python is swapped for the headless build).
mot-venv: $(MSTAMP)

$(MSTAMP): requirements-mot.txt
	test -x $(MOTV)/bin/python || $(PY) -m venv $(MOTV)
	$(MOTV)/bin/python -m pip install $(PIP_FLAGS) --no-deps -r requirements-mot.txt
	touch $@

# Training-only venv (PyTorch CPU) for the Siamese appearance nets; the runtime never needs it.
train-venv: $(TSTAMP)

$(TSTAMP): requirements-train.txt setup.py
	test -x $(TRAIN)/bin/python || $(PY) -m venv $(TRAIN)
	$(TRAIN)/bin/python -m pip install $(PIP_FLAGS) -r requirements-train.txt
	$(TRAIN)/bin/python -m pip install $(PIP_FLAGS) --no-deps -e .
	touch $@

train: $(TSTAMP)
	$(TRAIN)/bin/python training/train_siamese.py

lint: $(STAMP)
	$(VENV)/bin/ruff check .

# The suite also checks OpenCV's trackers (.venv-bench) and the ONNX export against torch (.venv-train).
test: $(STAMP) $(BSTAMP) $(TSTAMP)
	$(VENV)/bin/ruff check .
	$(VPY) -m pytest test -q -p no:cacheprovider

regress: $(STAMP)
	$(VENV)/bin/harness regress

demo: $(STAMP)
	$(VENV)/bin/demo --out out/demo

# SWEEP_ARGS, e.g. "--scenes all --seeds 3" or "--load" (docs/demo.md).
SWEEP_ARGS ?= --scenes demo --seeds 10
demo-sweep: $(STAMP)
	$(VENV)/bin/demo sweep --out out/sweep $(SWEEP_ARGS)

bench: $(STAMP) $(BSTAMP)
	$(VPY) benchmarks/core_speed.py
	$(VPY) benchmarks/node_latency.py

clean:
	rm -rf $(VENV) $(BENCH) $(TRAIN) build install log out *.egg-info
