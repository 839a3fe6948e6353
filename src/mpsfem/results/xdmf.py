"""XDMF sidecar so ParaView opens the particle snapshots of a results file as a time series."""

from __future__ import annotations

from pathlib import Path
from xml.sax.saxutils import quoteattr

import h5py


def xdmf_path(results_path: str | Path) -> Path:
    p = Path(results_path)
    return p.with_suffix(".xdmf")


def write_xdmf(h5: h5py.File, out: str | Path) -> Path:
    """Write ``out`` describing every ``/particles/<k>`` snapshot of the open file ``h5`` but a
    failed step's state (attribute ``failure``: not a time of the series)."""
    out = Path(out)
    href = Path(h5.filename).name
    grids = []
    for key in sorted(h5["particles"]):
        g = h5["particles"][key]
        if "failure" in g.attrs:
            continue
        n, dim = g["pos"].shape
        geom = "XY" if dim == 2 else "XYZ"
        path = f"{href}:/particles/{key}"
        grids.append(
            f'      <Grid Name="{key}" GridType="Uniform">\n'
            f'        <Time Value="{float(g.attrs["time"])!r}"/>\n'
            f'        <Topology TopologyType="Polyvertex" NumberOfElements="{n}"/>\n'
            f'        <Geometry GeometryType="{geom}">\n'
            f'          <DataItem Dimensions="{n} {dim}" NumberType="Float" Precision="8" '
            f'Format="HDF">{path}/pos</DataItem>\n'
            f"        </Geometry>\n"
            f'        <Attribute Name="velocity" AttributeType="Vector" Center="Node">\n'
            f'          <DataItem Dimensions="{n} {dim}" NumberType="Float" Precision="8" '
            f'Format="HDF">{path}/vel</DataItem>\n'
            f"        </Attribute>\n"
            f'        <Attribute Name="pressure" AttributeType="Scalar" Center="Node">\n'
            f'          <DataItem Dimensions="{n}" NumberType="Float" Precision="8" '
            f'Format="HDF">{path}/p</DataItem>\n'
            f"        </Attribute>\n"
            f'        <Attribute Name="kind" AttributeType="Scalar" Center="Node">\n'
            f'          <DataItem Dimensions="{n}" NumberType="Int" Precision="1" '
            f'Format="HDF">{path}/kind</DataItem>\n'
            f"        </Attribute>\n"
            f"      </Grid>\n"
        )
    text = (
        '<?xml version="1.0" ?>\n<Xdmf Version="3.0">\n  <Domain>\n'
        f'    <Grid Name={quoteattr("particles")} GridType="Collection" CollectionType="Temporal">\n'
        + "".join(grids)
        + "    </Grid>\n  </Domain>\n</Xdmf>\n"
    )
    tmp = out.with_name(out.name + ".tmp")
    tmp.write_text(text)
    tmp.replace(out)
    return out
