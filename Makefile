# Two commands on a fresh machine: `make run` and `make test`. Both are idempotent.
PYTHON ?= python3.11
VENV   := .venv
PY     := $(VENV)/bin/python
PIP    := $(PY) -m pip
# torch's CPU wheel lies on this machine's disk; a bare `torch` pulls GBs of CUDA packages.
TORCH  := torch==2.13.0
# Debian packages a headless GUI (Qt offscreen, polyscope EGL) needs.
DEB_PKGS := libgl1-mesa-dri libglx-mesa0 libegl-mesa0 libegl1 libgbm1 libxkbcommon0 \
            libxcb-icccm4 libxcb-keysyms1 libxcb-xinerama0 libxcb-cursor0 libfontconfig1 libdbus-1-3 xvfb

.PHONY: run test bench bench-load bench-engine clean

$(VENV)/.base: pyproject.toml
	test -x $(PY) || $(PYTHON) -m venv $(VENV) || python3 -m venv $(VENV)
	$(PIP) install -q --upgrade pip
	$(PIP) show torch >/dev/null 2>&1 || $(PIP) install -q $(TORCH)
	$(PIP) install -q -e .
	touch $@

$(VENV)/.app: $(VENV)/.base
	$(PIP) install -q -e '.[app]'
	touch $@

$(VENV)/.test: $(VENV)/.base
	$(PIP) install -q -e '.[test]'
	touch $@

.deb-stamp:
	@missing=""; for p in $(DEB_PKGS); do dpkg -s $$p >/dev/null 2>&1 || missing="$$missing $$p"; done; \
	if [ -n "$$missing" ]; then \
	  echo "installing Debian packages:$$missing"; \
	  SUDO=""; [ "$$(id -u)" = 0 ] || SUDO=sudo; \
	  $$SUDO apt-get update -qq && DEBIAN_FRONTEND=noninteractive $$SUDO apt-get install -y -qq $$missing >/dev/null; \
	fi
	@touch $@

run: $(VENV)/.app .deb-stamp
	$(VENV)/bin/scribbleseg-app

test: $(VENV)/.test .deb-stamp
	QT_QPA_PLATFORM=offscreen OPENBLAS_NUM_THREADS=1 $(VENV)/bin/lint-imports
	QT_QPA_PLATFORM=offscreen $(PY) -m pytest --durations=15 $(PYTEST_ARGS)

bench-load: $(VENV)/.base
	$(PY) -m scribbleseg_core.evaluation.load_speed

bench: $(VENV)/.base
	$(PY) -m scribbleseg_core.evaluation.signature_speed

bench-engine: $(VENV)/.base
	OPENBLAS_NUM_THREADS=1 $(VENV)/bin/scribbleseg bench ../shared/psb --mode both --out out/bench

clean:
	rm -rf $(VENV) .deb-stamp .pytest_cache
