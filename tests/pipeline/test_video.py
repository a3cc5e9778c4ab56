"""The pictures: the contact sheet's labels."""

import numpy as np

from pipeline import video


def test_label_writes_its_text_at_the_bottom_left():
    picture = np.full((20, 60, 3), 40, np.uint8)
    video.label(picture, "36 0.030 13s")
    white = np.all(picture == 255, axis=2)
    assert white[-7:, :48].any() and not white[:-7].any() and not white[:, 48:].any()
    # Each character is its three columns and a blank one: "1" differs from "7".
    one, seven = (video.label(np.zeros((7, 8, 3), np.uint8), c)[..., 0] for c in "17")
    assert not np.array_equal(one, seven)


def test_sheet_labels_each_frame():
    frames = [np.full((18, 32, 3), 100, np.uint8) for _ in range(3)]
    sheet = video.contact_sheet(frames, columns=2, labels=["1", "2", "3"])
    assert sheet.shape == (36, 64, 3)
    for r, c in ((0, 0), (0, 1), (1, 0)):
        tile = sheet[r * 18 : (r + 1) * 18, c * 32 : (c + 1) * 32]
        assert (tile == 255).all(axis=2)[-7:, :8].any()
    assert (sheet[18:, 32:] == 0).all()  # no fourth frame


def test_the_sheet_names_what_the_animation_animates_under_its_frames():
    """The caption: capitals wrapped at spaces into lines as wide as the sheet, under the
    frames, which stay as they were; each letter its own glyph."""
    frames = [np.full((18, 32, 3), 100, np.uint8) for _ in range(2)]
    text = "animated: mesh 'Cube' (placement from frame 3)"
    sheet = video.contact_sheet(frames, columns=2, caption=text)
    assert np.array_equal(sheet[:18], video.contact_sheet(frames, columns=2))
    lines = -(-len(text) // 15)  # at most 15 characters of 4 pixels on a 64-pixel line
    assert sheet.shape[0] > 18 + 7 * (lines - 1) and (sheet[18:] == 255).any()
    glyphs = {c: video.caption_band(8, c)[..., 0].tobytes() for c in "ABCDEFGHIJKLMNOPQRSTUVWXYZ'();:"}
    assert len(set(glyphs.values())) == len(glyphs)
