"""sphpost.readers.vtk: VTK files (legacy .vtk, XML .vtu and .vtp) by VTK's
own readers, and the times of ParaView collections (.pvd).  VTK is the
optional extra of the package: pip install 'sphpost[vtk]'."""
import glob
import os
import xml.etree.ElementTree as ET

from ..exceptions import PostprocError


def read_vtk(path):
    """A VTK file by VTK's own readers: legacy .vtk (polydata or
    unstructured grid, ASCII or binary), XML .vtu and .vtp.  The time from
    the field data TimeValue (ParaView's convention) or TIME."""
    try:
        import vtk
        from vtk.util.numpy_support import vtk_to_numpy
    except ImportError:
        raise PostprocError("reading VTK files needs VTK, the package's optional extra: "
                            "pip install 'sphpost[vtk]' (pip install './postproc[vtk]' from "
                            "the repository), or Debian's python3-vtk9 with /usr/bin/python3")
    vtk.vtkObject.GlobalWarningDisplayOff()     # a bad file is our message, not VTK's
    low = path.lower()
    if low.endswith(".vtu"):
        reader = vtk.vtkXMLUnstructuredGridReader()
    elif low.endswith(".vtp"):
        reader = vtk.vtkXMLPolyDataReader()
    else:
        reader = vtk.vtkGenericDataObjectReader()
    reader.SetFileName(path)
    if hasattr(reader, "ReadAllScalarsOn"):
        reader.ReadAllScalarsOn()
        reader.ReadAllVectorsOn()
        reader.ReadAllFieldsOn()
    reader.Update()
    ds = reader.GetOutput()
    pts = ds.GetPoints() if ds is not None and hasattr(ds, "GetPoints") else None
    if pts is None or ds.GetNumberOfPoints() == 0:
        raise PostprocError(f"{path}: not a readable VTK file with points (expected legacy "
                            "polydata or unstructured grid, .vtu or .vtp)")
    data = {}
    pd = ds.GetPointData()
    for k in range(pd.GetNumberOfArrays()):
        a = pd.GetAbstractArray(k)
        if a is not None and a.GetName() and hasattr(a, "GetNumberOfComponents"):
            try:
                data[a.GetName()] = vtk_to_numpy(a)
            except Exception:   # noqa: BLE001 (a string array: not a field of ours)
                pass
    time = None
    fd = ds.GetFieldData()
    for name in ("TimeValue", "TIME", "Time", "time"):
        a = fd.GetArray(name) if fd is not None else None
        if a is not None and a.GetNumberOfTuples() > 0:
            time = float(a.GetTuple1(0))
            break
    return data, time, vtk_to_numpy(pts.GetData()).astype(float)


def pvd_times(directory):
    """{file name: time} from the ParaView collections (*.pvd) of a directory."""
    out = {}
    for pvd in glob.glob(os.path.join(directory, "*.pvd")):
        try:
            root = ET.parse(pvd).getroot()
        except ET.ParseError as e:
            raise PostprocError(f"{pvd}: not a readable ParaView collection ({e})")
        for ds in root.iter("DataSet"):
            if ds.get("file") and ds.get("timestep") is not None:
                out[os.path.basename(ds.get("file"))] = float(ds.get("timestep"))
    return out
