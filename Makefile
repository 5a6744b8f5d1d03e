# The two set-up commands of the README:
#   make demo   installs what is missing, builds, renders the demo scene to out/
#   make test   installs what is missing, runs every test (Embree 3 system library, then Embree 4)
CARGO ?= cargo
BIN := target/release/caustica

.PHONY: demo test test-slurm setup build bench-backends dragon

setup:
	scripts/setup

build: setup
	$(CARGO) build --release

demo: build
	mkdir -p out
	$(BIN) render scenes/cornell-caustics.toml --spp 64 -o out/cornell-caustics.exr --png out/cornell-caustics.png --stats out/cornell-caustics.json
	@echo "wrote out/cornell-caustics.exr, out/cornell-caustics.png and out/cornell-caustics.json"

test: setup
	$(CARGO) test --release
	$(CARGO) build --release --no-default-features
	EMBREE4_TARGET_DIR=$(CURDIR)/target scripts/test-embree4

test-slurm: setup
	scripts/test-slurm

dragon:
	scripts/fetch-dragon

bench-backends: build dragon
	$(BIN) bench scenes/assets/models/teapot.obj build/dragon/*.ply.gz --json out/bench-backends.json
