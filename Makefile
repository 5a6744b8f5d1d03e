# The two set-up commands of the README:
#   make demo   installs what is missing, builds, renders the demo scene with mis and pt/pm/mis side by side to out/
#   make test   installs what is missing (OIDN for the denoising test: scripts/setup-oidn), runs every test
#               (Embree 3 system library, then Embree 4)
CARGO ?= cargo
BIN := target/release/caustica

.PHONY: demo test test-slurm setup build bench-backends dragon

setup:
	scripts/setup

build: setup
	$(CARGO) build --release

# The demo: cornell-caustics rendered with the paper's method (mis) for 10 s, then pt, pm and mis for 15 s
# each (equal time), side by side with their RMSE against the Mitsuba reference shipped in the repository.
REF := scenes/reference/cornell-caustics/mitsuba-path-9984spp.exr
demo: build
	mkdir -p out
	$(BIN) render scenes/cornell-caustics.toml --estimator mis --time-limit 10 -o out/cornell-caustics.exr --png out/cornell-caustics.png --stats out/cornell-caustics.json
	$(BIN) converge scenes/cornell-caustics.toml --reference $(REF) --time-budget 15 --region caustic=62%,86%,80%,94% -q -o out/cornell-caustics-converge
	cp out/cornell-caustics-converge/side-by-side.png out/cornell-caustics-side-by-side.png
	@echo "wrote out/cornell-caustics.exr (.png, .json) and out/cornell-caustics-side-by-side.png (pt, pm, mis at equal time, RMSE against $(REF))"

# `--tests`: the library's unit tests and tests/suite/ (examples are compiled by the check below instead of
# being linked with LTO here).
test: setup
	scripts/setup-oidn
	$(CARGO) test --release --tests
	$(CARGO) check --release --no-default-features --all-targets
	EMBREE4_TARGET_DIR=$(CURDIR)/target scripts/test-embree4

test-slurm: setup
	scripts/test-slurm

dragon:
	scripts/fetch-dragon

bench-backends: build dragon
	$(BIN) bench scenes/assets/models/teapot.obj build/dragon/*.ply.gz --json out/bench-backends.json
