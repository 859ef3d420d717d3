import numpy as np
from PIL import Image

from mnss_kit.eval.crops import LABEL_HEIGHT, error_heat, write_crops


def test_error_heat_runs_from_black_to_white():
    heat = error_heat(np.array([[0.0, 0.25, 1.0]]))
    assert heat[0, 0].tolist() == [0, 0, 0] and heat[0, 1].tolist() == [255, 255, 255] == heat[0, 2].tolist()


def test_the_error_map_under_a_method_is_bright_only_where_it_differs(tmp_path):
    reference = np.full((32, 32, 3), 0.5)
    wrong = reference.copy()
    wrong[:, 16:] = 1.0  # right half wrong
    path = next(p for p in write_crops(tmp_path, "s", 0, reference, {"m": wrong}) if p.name.endswith("centre.png"))
    image = np.asarray(Image.open(path).convert("RGB")).astype(int)
    side = (image.shape[0] - 2 * LABEL_HEIGHT - 8) // 2
    top, left = 2 * LABEL_HEIGHT + side + 4, 4 + side + 4  # error row, method column
    error_map = image[top : top + side, left : left + side]
    assert error_map[:, : side // 2 - 2].max() == 0
    assert error_map[:, side // 2 + 2 :].min() > 100
