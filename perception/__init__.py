"""Perception: where the parts are and what the human holds, from camera frames.

Data flow: frames -> detections -> sightings -> tracks -> world estimate, and
detections -> looks at faces -> outlines in the estimate.

- `frames`: `Frame`, the `FrameSource` protocol, webcam / video file / image folder
  sources, `open_source(spec)`, `SourceError`.
- `intrinsics`: `CameraIntrinsics` (default from a 60 deg field of view, JSON files,
  chessboard calibration).
- `markers`: payloads of part codes (``TDM:P:<marker>:<part>``) and bench reference
  codes (``TDM:R:<name>``), `corner_references` for the four corners of the bench.
- `codes_image`, `sheet`: QR symbols drawn by segno; `render_marker_sheet` prints
  them at true size on A4 PNG or PDF pages.
- `decode`: `decode_codes(image)` with zxing-cpp -> `Detection` (code, 4 corners).
- `pose`: `locate_camera` (the camera in the bench frame from the reference codes),
  `locate_parts` -> `PartSighting` (each part code's position in the bench frame).
- `observe`: `BenchObserver.observe(frame)` -> `FrameObservation`.
- `tracking`: `Tracker` -> one `Track` per part (median smoothing, jump hysteresis,
  confidence, timeout to unknown at the last known position).
- `part_moves`: `MoveWatch` / `part_moves` -> `PartMove` (a part's code leaving the
  pose it rested at until it settles at a new one or goes out of sight: from
  pose, to pose, start, end), from raw sightings over time.
- `layout`: `BenchLayout` (regions, bench top, extents, part shapes and slots).
- `world`: `WorldEstimator` -> `WorldEstimate` (each part on the bench in a region,
  held by the human or the robot, attached to a part at a slot, or unknown; the
  human's hands; stability).
- `outline`: a part's top-face outline (circle, square, triangle) in one frame, on
  the plane its code's corners give; `outline_watch`: `OutlineWatch`, the outline
  most recent looks read (`PartEstimate.outline`); `outline_bench`: a bench of
  such parts with known truth, and the share of looks right.
- `pipeline`: `BenchPerception.process(frame)` runs the whole chain.
- `annotate`: a frame with its decoded codes boxed and labelled and the bench axes.
- `sim`: `SimulatedCamera` (a `FrameSource` rendering a `SimScene` with pybullet,
  parts as boxes, cylinders or triangular prisms),
  `write_video`; `paper_bench`: the paper's base bench as layout and scene.
- `bench`: ``python -m perception.bench`` times the chain and maps detection rates.

Nothing here knows about plans or scenario files: the app converts a scenario into
a `BenchLayout` and a `SimScene`, and maps `WorldEstimate`s onto outcomes.
"""
