"""Transfer functions, pre-integration tables and the ray marcher: ``volcl render`` into a numpy image."""
from __future__ import annotations

import json
import os
from typing import Any, Dict, List, Optional, Sequence, Tuple, Union

import numpy as np

from . import _arrays, _volcl
from ._volume import Volume, read


class TransferFunction:
    """Piecewise-linear colour c(s) and extinction tau(s) in data units (tau per unit world length),
    constant beyond the end points; two points at the same s make a step.

    Build one from points, or read the canonical JSON, a ParaView colour map (``RGBPoints``/``Points``,
    opacity a per unit distance imported as tau = -ln(1 - a) / unit_distance), a built-in preset or a 1D
    RGBA strip image::

        tf = volcl.TransferFunction(domain=(0, 255),
                                    color=[(0, 0, 0, 0), (128, 1, .6, .2), (255, 1, 1, 1)],
                                    extinction=[(0, 0), (60, 0), (80, .8), (255, .05)])
        tf = volcl.TransferFunction.from_file("paraview_colormap.json")
        tf = volcl.TransferFunction.preset("viridis")   # normalised: spread over the data range on render
    """

    def __init__(self, domain: Sequence[float] = (0.0, 255.0),
                 color: Sequence[Sequence[float]] = ((0.0, 0.0, 0.0, 0.0), (255.0, 1.0, 1.0, 1.0)),
                 extinction: Sequence[Sequence[float]] = ((0.0, 0.0), (255.0, 1.0)), *,
                 _native: Optional["_volcl.TransferFunction"] = None) -> None:
        if _native is None:
            text = json.dumps({"domain": [float(v) for v in domain],
                               "color": [[float(v) for v in p] for p in color],
                               "extinction": [[float(v) for v in p] for p in extinction]})
            _native = _volcl.TransferFunction.from_json(text, 1.0)
        self._native = _native

    @classmethod
    def from_file(cls, path: Union[str, "os.PathLike[str]"], *, strip_domain: Sequence[float] = (0.0, 255.0),
                  unit_distance: float = 1.0) -> "TransferFunction":
        """Canonical JSON, ParaView colour-map JSON (detected by its keys), or a 1D RGBA strip (.png/.exr)
        spanning ``strip_domain``. ``unit_distance``: the world length over which an imported opacity holds
        (ParaView's scalar opacity unit distance)."""
        p = os.fspath(path)
        with _arrays.missing_file_check(p):
            return cls(_native=_volcl.TransferFunction.from_file(p, tuple(strip_domain), float(unit_distance)))

    @classmethod
    def from_json(cls, text: Union[str, Dict[str, Any], List[Any]], *, unit_distance: float = 1.0
                  ) -> "TransferFunction":
        """Canonical or ParaView JSON, as a string or as the parsed object."""
        if not isinstance(text, str):
            text = json.dumps(text)
        return cls(_native=_volcl.TransferFunction.from_json(text, float(unit_distance)))

    @classmethod
    def preset(cls, name: str, *, unit_distance: float = 1.0) -> "TransferFunction":
        """A built-in preset (see :meth:`preset_names`), normalised to [0, 1]."""
        return cls(_native=_volcl.TransferFunction.preset(name, float(unit_distance)))

    @staticmethod
    def preset_names() -> List[str]:
        """Names :meth:`preset` accepts (the command line's ``--tf preset:NAME``)."""
        return list(_volcl.TransferFunction.preset_names())

    @property
    def domain(self) -> Tuple[float, float]:
        """The data range (lo, hi) the function is defined over (pre-integration tables span it)."""
        return tuple(self._native.domain)  # type: ignore[return-value]

    @property
    def color(self) -> List[Tuple[float, float, float, float]]:
        """Colour control points (s, r, g, b)."""
        return [tuple(p) for p in self._native.color]  # type: ignore[misc]

    @property
    def extinction(self) -> List[Tuple[float, float]]:
        """Extinction control points (s, tau)."""
        return [tuple(p) for p in self._native.extinction]  # type: ignore[misc]

    @property
    def normalized(self) -> bool:
        """True for a preset authored on [0, 1]: a render spreads it over the data's value range."""
        return bool(self._native.normalized)

    def color_at(self, s: float) -> Tuple[float, float, float]:
        """c(s), exact (double precision)."""
        return tuple(self._native.color_at(float(s)))  # type: ignore[return-value]

    def extinction_at(self, s: float) -> float:
        """tau(s), exact (double precision)."""
        return float(self._native.extinction_at(float(s)))

    def rescaled(self, value_range: Sequence[float]) -> "TransferFunction":
        """The same function with every point and the domain mapped linearly onto ``value_range``."""
        return TransferFunction(_native=self._native.rescaled(tuple(value_range)))

    def to_json(self) -> str:
        """The canonical JSON (what ``volcl render --tf`` reads)."""
        return self._native.to_json()

    def to_dict(self) -> Dict[str, Any]:
        """The canonical JSON, parsed."""
        return json.loads(self.to_json())

    def __repr__(self) -> str:
        return f"TransferFunction(domain={self.domain}, {len(self.color)} colour / " \
               f"{len(self.extinction)} extinction points)"


TF = TransferFunction

TfLike = Union[TransferFunction, str, "os.PathLike[str]", Dict[str, Any]]


def as_transfer_function(tf: TfLike) -> TransferFunction:
    """A TransferFunction from a TransferFunction, a parsed JSON dict, "preset:NAME", or a file path."""
    if isinstance(tf, TransferFunction):
        return tf
    if isinstance(tf, dict):
        return TransferFunction.from_json(tf)
    text = os.fspath(tf)
    if text.startswith("preset:"):
        return TransferFunction.preset(text[len("preset:"):])
    return TransferFunction.from_file(text)


def _render_tf(tf: Optional[TfLike]):
    """(native TF or None, preset/file spec or None) for _volcl.render: presets and files are read there,
    with the volume's automatic opacity unit distance."""
    if tf is None:
        return None, None
    if isinstance(tf, (str, os.PathLike)):
        return None, os.fspath(tf)
    return as_transfer_function(tf)._native, None


def preintegration_table(tf: TfLike, *, size: int = 256, step: Optional[float] = None,
                         lengths: Optional[int] = None, max_length: Optional[float] = None,
                         axis: str = "linear", method: str = "exact", precision: str = "float",
                         device: Optional[str] = None) -> np.ndarray:
    """The pre-integration table ``volcl preint`` writes, as a float32 array of associated RGBA.

    2D (``step=d``): shape (N, N, 4), entry [front, back] for a segment of length d whose scalar runs from
    node ``front`` to node ``back`` (node i at ``lo + i (hi - lo) / (N - 1)`` over the TF domain).
    3D (``lengths=L, max_length=D``): shape (L, N, N, 4), slice k for length ``(k + 1) D / L`` (``axis``
    "exponential": Guthe's spacing). ``method``: exact | reference | incremental | integral-function |
    roettger2d | polynomial (see docs/preintegration.md); "reference" runs on the host in double.
    """
    t = as_transfer_function(tf)
    ctx = None if method == "reference" else _arrays.context(device)
    table, _ = _volcl.preintegration_table(ctx, t._native, int(size), None if step is None else float(step),
                                           None if lengths is None else int(lengths),
                                           None if max_length is None else float(max_length), axis, method,
                                           precision)
    return table


def render(volume: Union[Volume, np.ndarray, str, "os.PathLike[str]"], tf: Optional[TfLike] = None, *,
           camera: Optional[Dict[str, Any]] = None, view: Optional[str] = None, mode: str = "dvr",
           width: int = 512, height: int = 512, step: Union[float, str, None] = None, preintegration: str = "none",
           early_termination: float = 0.995, background: Optional[Sequence[float]] = None,
           lights: Optional[List[Dict[str, Any]]] = None, effects: Optional[Dict[str, Any]] = None,
           options: Optional[Dict[str, Any]] = None, spacing: Optional[Sequence[float]] = None,
           origin: Optional[Sequence[float]] = None, frame: int = 0, device: Optional[str] = None
           ) -> np.ndarray:
    """Ray-marches a volume as ``volcl render`` does and returns its EXR image as a float32 array
    [height, width, 4]: linear, associated RGBA (``rgb`` = integral of emission x transmittance, ``a`` =
    1 - total transmittance), no background; a fifth channel Z (depth) when iso-surfaces are drawn.
    Row 0 is the top of the image.

    ``volume``: a :class:`Volume`, a 3D array (with ``spacing``/``origin``), or a file path (frame
    ``frame`` of a series). ``tf``: a :class:`TransferFunction`, a JSON dict, a file or "preset:NAME"; a
    file or preset is read with ParaView's automatic opacity unit distance (box diagonal / cube root of the
    cell count) and spread over the data range, and without ``tf`` the image uses ParaView's default (a
    grey ramp with opacity 0 to 1 over the data range), all as ``volcl render`` does.
    The scene fields follow the scene JSON: ``camera`` (``{"projection": "orthographic", "eye": [...],
    "target": [...], "up": [...], "height": h}`` or ``"fov_y_deg"`` for perspective; default: looking
    down +z at the whole box, or the front view for a file placed in patient axes, as ``volcl render``),
    or ``view`` (front | back | left | right | top | bottom | iso, framed as ParaView's reset camera, in
    world axes: patient RAS for NIfTI, NRRD and MetaImage files, so front shows the face whatever the
    storage order); ``mode`` (dvr | mip | iso | xray | emission), ``step`` (a number: world units; "Nvox": voxels of the finest
    spacing; default half a voxel),
    ``preintegration`` (none | 2d | 3d), ``early_termination``, ``lights``, ``effects``; ``options``
    adds further keys of the scene's "render" object. The GIL is released while the kernel runs.

    Example::

        img = volcl.render(vol, "preset:viridis", view="front", width=256, height=256)
        plt.imshow(volcl.composite(img))   # over black, sRGB
    """
    metadata: Dict[str, Any] = {}
    if isinstance(volume, (str, os.PathLike)):
        v = read(volume, device=device)
        array = v.frame(frame)
        spacing, origin, metadata = v.spacing, v.origin, v.metadata
    elif isinstance(volume, Volume):
        array = volume.frame(frame)
        spacing = volume.spacing if spacing is None else spacing
        origin = volume.origin if origin is None else origin
        metadata = volume.metadata
    else:
        array = np.asarray(volume)
    # Oriented data frames as the command line does: views in world (patient RAS) axes, and a volume
    # placed in patient axes defaults to the front view.
    direction = tuple((metadata or {}).get("direction", (1, 0, 0, 0, 1, 0, 0, 0, 1)))
    if view is None and camera is None and (metadata or {}).get("anatomical", False):
        view = "front"
    a = _arrays.volume_array(array)
    render_section: Dict[str, Any] = {"mode": mode, "preintegration": preintegration,
                                      "early_termination": float(early_termination)}
    if step is not None:
        render_section["step"] = step if isinstance(step, str) else float(step)
    render_section.update(options or {})
    scene: Dict[str, Any] = {"image": {"width": int(width), "height": int(height)}, "render": render_section}
    if background is not None:
        scene["image"]["background"] = [float(c) for c in background]
    if camera is not None:
        scene["camera"] = camera
    if lights is not None:
        scene["lights"] = lights
    if effects is not None:
        scene["effects"] = effects
    image, _channels = _volcl.render(_arrays.context(device), a, _arrays.triple(spacing, 1.0, "spacing"),
                                     _arrays.triple(origin, 0.0, "origin"), *_render_tf(tf),
                                     json.dumps(scene), view, direction)
    return image


def composite(image: np.ndarray, background: Sequence[float] = (0.0, 0.0, 0.0, 1.0)) -> np.ndarray:
    """An associated-RGBA render composited over ``background`` (RGBA) and sRGB-encoded, float32 in [0, 1]
    [height, width, 4]: the PNG ``volcl render`` writes, before quantisation to 8 bit (for matplotlib)."""
    rgba = np.ascontiguousarray(image, dtype=np.float32)
    return _volcl.composite(rgba, tuple(float(c) for c in background))
