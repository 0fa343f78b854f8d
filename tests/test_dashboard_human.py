"""The human on the bench's page stands at full height with its name just above its
head (real chromium, the real meshes)."""

from __future__ import annotations

import io
import time
from collections.abc import Iterator

import numpy as np
import pytest
from PIL import Image

pytest.importorskip("playwright.sync_api")
from playwright.sync_api import Browser, Page  # noqa: E402

from app.dashboard.server import Dashboard  # noqa: E402
from tests.test_dashboard import opened, served, shot, wait_for  # noqa: E402, F401

Box = tuple[int, int, int, int]  # left, top, right, bottom, in pixels


@pytest.fixture(scope="module")
def dashboard(tmp_path_factory: pytest.TempPathFactory) -> Iterator[Dashboard]:
    with served(tmp_path_factory.mktemp("data"), load_models=True) as d:
        yield d


def _picture(page: Page) -> np.ndarray:
    return np.asarray(Image.open(io.BytesIO(page.screenshot())).convert("RGB"), dtype=int)


def _human_pixels(image: np.ndarray) -> Box | None:
    """The box of the human's strongly blue body (nothing else on the page is)."""
    r, g, b = image[..., 0], image[..., 1], image[..., 2]
    rows, cols = np.nonzero((b > 150) & (r < 60) & (g < 60))
    if len(rows) < 500:
        return None
    return int(cols.min()), int(rows.min()), int(cols.max()), int(rows.max())


def _name_above(image: np.ndarray, body: Box) -> Box | None:
    """The box of the dark text over the body's columns above its top: the name
    (labels are drawn in the 3D picture, not in the page's text)."""
    band = image[: body[1], body[0] : body[2] + 1]
    rows, cols = np.nonzero((band < 90).all(axis=-1))
    if len(rows) == 0:
        return None
    return body[0] + int(cols.min()), int(rows.min()), body[0] + int(cols.max()), int(rows.max())


def _settled(page: Page) -> np.ndarray:
    """The picture once the human's box is the same in two pictures a second apart
    (software WebGL draws the meshes as they arrive)."""
    last: Box | None = None
    end = time.monotonic() + 120
    while time.monotonic() < end:
        image = _picture(page)
        now = _human_pixels(image)
        if now is not None and now == last:
            return image
        last = now
        time.sleep(1.0)
    raise AssertionError(f"the human's picture never settled: {last}")


@pytest.mark.parametrize("size", [(1600, 1000), (1280, 800)])
def test_the_human_stands_with_its_name_above_its_head(
    browser: Browser, dashboard: Dashboard, size: tuple[int, int]
) -> None:
    with opened(browser, dashboard) as page:
        page.set_viewport_size({"width": size[0], "height": size[1]})
        image = _settled(page)
        shot(page, f"human-{size[0]}x{size[1]}")
        body = _human_pixels(image)
        assert body is not None
        # Drawn standing: the blue head and body alone over a quarter of the page high
        # (its limbs used to be heaped at the pelvis, a short blob far below its name).
        assert body[3] - body[1] > size[1] / 4, body
        # The name sits just above the head, over the body.
        name = _name_above(image, body)
        assert name is not None, body
        gap = body[1] - name[3]
        assert gap <= 30 and name[2] - name[0] >= 20, (gap, body, name)
    wait_for(lambda: not dashboard.server.get_clients(), 10)
