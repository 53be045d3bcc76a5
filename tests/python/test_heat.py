"""The false-colour view of counts: one fixed colour map on a fixed, stated scale (raylab.heat_map), and
a legend a user can read (raylab.heat_legend, heat_ticks, heat_scale_text)."""
import numpy as np
import pytest

import raylab
from raylab import heat


def luminance(rgba):
    return rgba[..., :3] @ np.array([0.2126, 0.7152, 0.0722], np.float32)


def test_the_scale_runs_from_the_first_colour_at_zero_to_the_last_at_the_maximum_and_above():
    image = raylab.heat_map(np.array([[0, 50, 100], [150, 1e9, -3]]), maximum=100)
    assert image.shape == (2, 3, 4) and image.dtype == np.float32
    assert (image[..., 3] == 1).all()
    first, last = raylab.heat_map(np.array([0.0, 100.0]), 100)
    assert np.array_equal(image[0, 0], first) and np.array_equal(image[0, 2], last)
    assert np.array_equal(image[1, 0], last) and np.array_equal(image[1, 1], last)   # above: the top colour
    assert np.array_equal(image[1, 2], first)                                         # below 0: the bottom
    ramp = raylab.heat_map(np.linspace(0, 100, 201), 100)
    assert (np.diff(luminance(ramp)) > 0).all(), "more work must always look brighter"


def test_the_scale_is_fixed_the_same_count_has_the_same_colour_in_any_image():
    cheap = np.array([[1, 2], [3, 40]])
    costly = np.array([[40, 400], [4000, 3]])
    a, b = raylab.heat_map(cheap, 500), raylab.heat_map(costly, 500)
    assert np.array_equal(a[1, 1], b[0, 0]) and np.array_equal(a[1, 0], b[1, 1])
    assert not np.array_equal(raylab.heat_map(cheap, 50)[1, 1], a[1, 1])  # another maximum, another scale


def test_the_colours_are_the_declared_map_in_linear_light():
    stops = raylab.heat_map(np.linspace(0, 8, 9), 8)[:, :3]
    srgb = raylab.HEAT_COLOURS
    linear = np.where(srgb <= 0.04045, srgb / 12.92, ((srgb + 0.055) / 1.055) ** 2.4)
    assert np.allclose(stops, linear, atol=1e-6)


@pytest.mark.parametrize("maximum", [0, -1, float("nan"), float("inf"), "100", True, None])
def test_a_bad_maximum_is_a_value_error_naming_it(maximum):
    with pytest.raises(ValueError, match="maximum"):
        raylab.heat_map(np.ones((2, 2)), maximum)
    with pytest.raises(ValueError, match="maximum"):
        raylab.heat_legend(maximum)


def test_bad_values_are_a_value_error_naming_them():
    with pytest.raises(ValueError, match="values"):
        raylab.heat_map(np.array([1.0, np.nan]), 10)
    with pytest.raises(ValueError, match="values"):
        raylab.heat_map(np.array(["a"]), 10)
    with pytest.raises(ValueError, match="width"):
        raylab.heat_legend(10, width=20)


def test_the_legend_states_the_scale_at_both_ends_and_the_middle():
    assert raylab.heat_ticks(200) == [(0.0, "0"), (100.0, "100"), (200.0, "200+")]
    assert raylab.heat_ticks(1500)[1:] == [(750.0, "750"), (1500.0, "1.5k+")]
    assert raylab.heat_ticks(2.5e6)[-1][1] == "2.5M+"
    text = raylab.heat_scale_text("Triangle tests", 200)
    assert text.startswith("Triangle tests per pixel: 0 (") and "200+" in text

    legend = raylab.heat_legend(200, width=240, bar_height=10)
    assert legend.shape == (10 + heat.LEGEND_TEXT_HEIGHT, 240, 4) and legend.dtype == np.float32
    bar, numbers = legend[:10], legend[10:]
    assert np.array_equal(bar[0], bar[-1])
    assert np.array_equal(bar[0], raylab.heat_map((np.arange(240) + 0.5) / 240 * 200, 200))
    ink = (numbers[..., :3] == 1).all(axis=2)
    columns = np.flatnonzero(ink.any(axis=0))
    # numbers at the left end, in the middle and at the right end, nothing else
    assert columns.min() < 10 and columns.max() > 230 and ink[:, 100:140].any()
    assert not ink[:, 20:90].any() and not ink[:, 150:200].any()
    # another maximum, other numbers under the same bar
    other = raylab.heat_legend(5000, width=240, bar_height=10)
    assert not np.array_equal(other[10:], numbers)
