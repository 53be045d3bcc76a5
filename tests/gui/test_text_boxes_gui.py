"""Issue 42 item 1 in a real Blender window under Xvfb: a Text object and a collection instance, which F12
renders, get the BVH's boxes in the viewport and a probe hit. Runs text_boxes_shot.py; the screenshots land
in out/gui/text_boxes_off.png and text_boxes_on.png."""

import pytest

import gui_util


@pytest.fixture(scope="module")
def text_boxes(tmp_path_factory):
    return gui_util.off_on_shots("text_boxes_shot.py", "text_boxes",
                                 gui_util.start_blend(tmp_path_factory.mktemp("text_boxes")))


def test_the_text_and_the_collection_instance_get_boxes(text_boxes):
    report, off, on = text_boxes
    assert set(report["drawn"]) == {"Text", "Suzanne"} and min(report["drawn"].values()) > 0, report["drawn"]
    changed = gui_util.changed(off, on, threshold=0.1)
    width = changed.shape[1]
    # Boxes drawn over the left half (the T) and the right half (the monkey), in the view's middle band.
    band = changed[changed.shape[0] // 4:3 * changed.shape[0] // 4]
    assert band[:, :width // 2].sum() > 500 and band[:, width // 2:].sum() > 500


def test_a_probe_ray_hits_the_text(text_boxes):
    report, _, _ = text_boxes
    assert report["probe"] == "hit_object", report["probe_text"]
