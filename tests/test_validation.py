"""Bad input gets a ValueError naming the argument."""

import numpy as np
import pytest

import forward


@pytest.mark.parametrize("kw,name", [
    (dict(chl=np.nan), "chl"), (dict(chl=-1), "chl"), (dict(cdom=np.inf), "cdom"),
    (dict(cdom=-0.1), "cdom"), (dict(depth=-1), "depth"), (dict(distance=np.nan), "distance"),
    (dict(depth=[1, 2]), "depth"),
])
def test_bad_scalars(kw, name):
    args = dict(chl=1.0, cdom=0.1, depth=5.0, distance=1.0)
    args.update(kw)
    with pytest.raises(ValueError, match=f"^{name}:"):
        forward.simulate_chart(**args)


@pytest.mark.parametrize("wl", [np.arange(380, 701, 10.0), np.arange(400, 731, 10.0),
                                [400, 500, np.nan], [500, 450, 600], [400, 500]])
def test_bad_grid(wl):
    with pytest.raises(ValueError, match="^wavelengths:"):
        forward.simulate_chart(1, 0.1, 5, 1, wavelengths=wl)


def test_camera_not_covering_grid(tmp_path):
    # curves that stop while still high (here 450-700 nm at half their peak) are refused; the
    # Sigma's, which have fallen to ~0 at their 680 nm end, are taken as 0 beyond it
    wl = np.arange(450.0, 701.0, 5.0)
    f = tmp_path / "cam.csv"
    f.write_text("wavelength,red,green,blue\n" + "".join(f"{w:g},0.5,0.5,0.5\n" for w in wl))
    with pytest.raises(ValueError, match="^camera:.*cover"):
        forward.simulate_chart(1, 0.1, 5, 1, camera=f)
    assert forward.simulate_chart(1, 0.1, 5, 1, camera="Sigma SDMerill (NPL)").rgb.shape == (3, 24)
    with pytest.raises(ValueError, match="^camera: unknown"):
        forward.simulate_chart(1, 0.1, 5, 1, camera="Nokia")


def test_wrong_shapes():
    with pytest.raises(ValueError, match="^camera:"):
        forward.simulate_chart(1, 0.1, 5, 1, camera=np.ones((30, 3)))
    with pytest.raises(ValueError, match="^reflectances:"):
        forward.simulate_chart(1, 0.1, 5, 1, reflectances=np.ones((24, 301)))
    with pytest.raises(ValueError, match="^reflectances:"):
        forward.simulate_chart(1, 0.1, 5, 1, reflectances=-np.ones((301, 24)))
    with pytest.raises(ValueError, match="^illuminant:"):
        forward.simulate_chart(1, 0.1, 5, 1, illuminant=np.ones(5))
    with pytest.raises(ValueError, match="^basis:"):
        forward.simulate_chart(1, 0.1, 5, 1, basis=np.ones((20, 1)))
    with pytest.raises(ValueError, match="^path_model:"):
        forward.simulate_chart(1, 0.1, 5, 1, path_model="fog")
    with pytest.raises(ValueError, match="^seed:"):
        forward.simulate_chart(1, 0.1, 5, 1, seed=-3)
    with pytest.raises(ValueError, match="^pixels_per_patch:"):
        forward.SensorSettings(pixels_per_patch=0)


def test_public_functions_validate():
    with pytest.raises(ValueError, match="^chl:"):
        forward.absorption(None, -1.0, 0.1)
    with pytest.raises(ValueError, match="^cdom:"):
        forward.attenuation_coefficient(None, 1.0, np.nan)
    with pytest.raises(ValueError, match="^chl:"):
        forward.scattering(None, np.inf)
