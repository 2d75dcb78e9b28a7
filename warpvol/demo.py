"""The page ``warpvol demo`` writes: image, exact reference and error map side by side, a line on what
each is, and the error numbers explained (Jinja2 template ``warpvol/templates/demo.html``)."""

from __future__ import annotations

from warpvol.metrics import ERROR_FLOOR

#: the files ``demo -o`` writes
DEMO_FILES = ("image.exr", "reference.exr", "image.png", "reference.png", "error.png", "report.json", "index.html")
#: background of the demo's PNG images
DEMO_BACKGROUND = (0.1, 0.1, 0.1)


def demo_page(scene, report: dict, err_max: float) -> str:
    """The demo's ``index.html`` (Jinja2 template ``warpvol/templates/demo.html``): image, reference and
    error map side by side, a line on what each is, and the error numbers explained."""
    import jinja2


    env = jinja2.Environment(loader=jinja2.PackageLoader("warpvol", "templates"), autoescape=True,
                             undefined=jinja2.StrictUndefined)
    cam, e = scene.camera, report["error"]
    bg = ", ".join(f"{v:g}" for v in DEMO_BACKGROUND)
    figures = [
        dict(file="image.png", title="image", chart=False,
             text=f"what the {report['pipeline']} pipeline rendered: premultiplied RGBA composited over grey ({bg}), "
                  "8 bits per channel (full precision in image.exr)."),
        dict(file="reference.png", title="reference", chart=False,
             text="the exact float64 ray integral of the same scene (warpvol reference), composited the same way "
                  "(reference.exr)."),
        dict(file="error.png", title="error", chart=True,
             text=f"per pixel, the largest |image - reference| over R, G, B and A, on a logarithmic colour scale "
                  f"from {ERROR_FLOOR:.0e} to the maximum ({err_max:.2e}); one step of an 8-bit channel is 3.9e-3."),
    ]
    psnr = "exact (unbounded)" if e["psnr"] is None else f"{e['psnr']:.1f} dB"
    measures = [
        dict(name="RMSE", value=f"{e['rmse']:.3e}", text="root mean square of image - reference over every pixel "
             "and channel, background included"),
        dict(name="max abs", value=f"{e['max_abs']:.3e}", text="the largest |image - reference| of any pixel and "
             "channel (below 3.9e-3 it is invisible in an 8-bit PNG)"),
        dict(name="PSNR", value=psnr, text="20 log10(1 / RMSE), peak 1"),
        dict(name="frame", value=f"{report['render_s']:.3f} s", text="the warm render (kernels compiled, set-up "
             "kept)"),
    ]
    return env.get_template("demo.html").render(
        scene=scene.name, pipeline=report["pipeline"], n_tets=f"{scene.mesh.n_tets:,}", width=cam.width_px,
        height=cam.height_px, figures=figures, measures=measures,
        files=["image.exr", "reference.exr", "report.json"])
