"""What a waiting question says (pure): the time waited, and what the camera and
the voice are doing while they may answer."""

from __future__ import annotations

from app.dashboard.wait_words import CameraNews, Waiting, wait_line


def test_a_camera_wait_says_what_it_sees_and_when_it_is_stuck() -> None:
    looking = wait_line(Waiting("n4", "sense(humanHolding)", 12.4,
                                CameraNews(3, 5, True, 0.1), camera_on=True))  # fmt: skip
    assert "`n4` **sense(humanHolding)**" in looking and "for 12 s" in looking
    assert "The camera is looking: seen 3 of 5 markers, settling" in looking
    assert looking.endswith("; or a click answers for the human.")
    stuck = wait_line(Waiting("n4", "sense(humanHolding)", 9.0,
                              CameraNews(3, 5, False, 6.0), camera_on=True))  # fmt: skip
    assert "no frame for 6 s" in stuck and "settling" not in stuck
    assert "no frame yet" in wait_line(Waiting("n4", "x", 1.0, None, camera_on=True))


def test_a_voice_wait_says_it_listens_and_what_it_heard() -> None:
    line = wait_line(Waiting("n9", "confirmAttach(foot2,leg2)", 4.0, voice=True,
                             heard="'maybe': asked again"))  # fmt: skip
    assert "The voice is listening; heard 'maybe': asked again" in line
    assert "camera" not in line and "a click answers" in line
