// NimbusModule.cpp: the Python module `nimbus`, a pybind11 binding of the C ABI (nimbus.hpp).
//
//   import nimbus
//   scene = nimbus.load("shot.json")                  # or nimbus.load_dict({...}), or in code:
//   scene = nimbus.Scene()
//   scene.camera["resolution"] = (320, 180)
//   scene.add(nimbus.Light("distant", direction=(0, -1, 0), irradiance=3))
//   scene.add(nimbus.Volume.from_grid(pyopenvdb_grid, {"medium.sigma_s": 2}))
//   frame = nimbus.render(scene, progress=lambda f: print(f))
//   beauty = frame["beauty"]                           # float32 (height, width, 4), no copy
//
// Values go through the same typed setters as C (docs/embedding.md, "Python"): int, float, str,
// sequences of numbers or strings, dicts (as JSON), so a scene built in code meets the scene
// format's checks. Renders release the GIL; progress callbacks take it back on the render thread.
//
// pyopenvdb grids are written to a temporary .vdb file and the volume references it. pyopenvdb
// keeps its grids behind boost.python (getGridFromPyObject lives in its own extension module,
// loaded RTLD_LOCAL, with OpenVDB's C++ ABI in the signature), so taking the C++ grid would tie
// this module to one boost.python and OpenVDB build; the file costs one write of the grid,
// renders through exactly the CLI's path, and keeps the scene exportable as JSON.
#include "nimbus.hpp"

#include <pybind11/functional.h>
#include <pybind11/numpy.h>
#include <pybind11/pybind11.h>
#include <pybind11/stl.h>

#include <atomic>
#include <memory>
#include <string>

namespace py = pybind11;
using namespace nimbus::embed;

namespace {

// ---- errors -------------------------------------------------------------------------------

// The exception types live as long as the interpreter: raw references, never released, so that
// no destructor runs after Python has been finalised.
PyObject* gError = nullptr;
PyObject* gInputError = nullptr;
PyObject* gCancelled = nullptr;

[[noreturn]] void raise(NimbusStatus status, const std::string& message)
{
    PyObject* t = gError;
    if (status == NIMBUS_ERROR_CANCELLED)
        t = gCancelled;
    else if (status == NIMBUS_ERROR_UNKNOWN_PARAMETER || status == NIMBUS_ERROR_WRONG_TYPE ||
             status == NIMBUS_ERROR_BAD_INPUT)
        t = gInputError;
    py::object type = py::reinterpret_borrow<py::object>(t);
    py::object exc = type(message);
    exc.attr("status") = nimbus_status_name(status);
    PyErr_SetObject(type.ptr(), exc.ptr());
    throw py::error_already_set();
}

void checkPy(NimbusStatus status)
{
    if (status != NIMBUS_OK)
        raise(status, nimbus_last_error());
}

// ---- parameters ---------------------------------------------------------------------------

bool isNumber(const py::handle& v)
{
    return !py::isinstance<py::bool_>(v) &&
           (py::isinstance<py::int_>(v) || py::isinstance<py::float_>(v) || py::hasattr(v, "__float__"));
}

std::string toJsonText(const py::handle& v)
{
    return py::module_::import("json").attr("dumps")(v).cast<std::string>();
}

// One Python value through the C setter of its type.
void setValue(NimbusHandle h, const std::string& name, const py::handle& value)
{
    py::object v = py::reinterpret_borrow<py::object>(value);
    if (py::hasattr(v, "ndim") && py::hasattr(v, "item") && v.attr("ndim").cast<int>() == 0)
        v = v.attr("item")();  // a numpy scalar: its Python number
    if (py::isinstance<py::bool_>(v) || v.is_none())
        checkPy(nimbus_set_json(h, name.c_str(), toJsonText(v).c_str()));  // the reader says what it expected
    else if (py::isinstance<py::int_>(v))
        checkPy(nimbus_set_int(h, name.c_str(), v.cast<int64_t>()));
    else if (py::isinstance<py::float_>(v))
        checkPy(nimbus_set_float(h, name.c_str(), v.cast<double>()));
    else if (py::isinstance<py::str>(v) || py::hasattr(v, "__fspath__"))
        checkPy(nimbus_set_string(h, name.c_str(),
                                  py::str(py::module_::import("os").attr("fspath")(v)).cast<std::string>().c_str()));
    else if (py::isinstance<py::dict>(v))
        checkPy(nimbus_set_json(h, name.c_str(), toJsonText(v).c_str()));
    else if (py::isinstance<py::sequence>(v) || py::hasattr(v, "tolist")) {
        py::list items = py::hasattr(v, "tolist") ? py::list(v.attr("tolist")()) : py::list(v);
        bool numbers = true, strings = true;
        for (auto item : items) {
            numbers &= isNumber(item);
            strings &= py::isinstance<py::str>(item);
        }
        if (numbers && items.size() > 0) {
            std::vector<double> values;
            for (auto item : items)
                values.push_back(item.cast<double>());
            checkPy(nimbus_set_floats(h, name.c_str(), values.data(), values.size()));
        } else if (strings) {
            std::vector<std::string> s;
            std::vector<const char*> p;
            for (auto item : items)
                s.push_back(item.cast<std::string>());
            for (auto& each : s)
                p.push_back(each.c_str());
            checkPy(nimbus_set_strings(h, name.c_str(), p.data(), p.size()));
        } else {
            checkPy(nimbus_set_json(h, name.c_str(), toJsonText(items).c_str()));
        }
    } else if (isNumber(v))
        checkPy(nimbus_set_float(h, name.c_str(), v.cast<double>()));
    else
        throw py::type_error("nimbus parameter '" + name + "': cannot pass a " +
                             py::str(py::type::of(v).attr("__name__")).cast<std::string>());
}

void setMany(NimbusHandle h, const py::dict& params)
{
    for (auto item : params)
        setValue(h, py::str(item.first).cast<std::string>(), item.second);
}

// Python-side objects own one reference each (nimbus::embed::Handle).
struct PyObjectBase {
    Handle handle;
    void set(const std::string& name, const py::object& v) { setValue(handle.get(), name, v); }
    void unset(const std::string& name) { checkPy(nimbus_unset(handle.get(), name.c_str())); }
    void commit() { checkPy(nimbus_commit(handle.get())); }
};

struct PyCamera : PyObjectBase {};
struct PyLight : PyObjectBase {};
struct PyVolume : PyObjectBase {};
struct PyScene : PyObjectBase {};

template <class T>
T adopt(NimbusHandle h)
{
    T o;
    o.handle = Handle::adopt(h);
    return o;
}

// ---- pyopenvdb grids ----------------------------------------------------------------------

// One temporary directory per process, removed at exit; each call writes a new file, so the
// volume sees the grids as they were when it was made.
std::string gridFile(const py::dict& grids)
{
    static std::atomic<int> counter{0};
    py::module_ tempfile = py::module_::import("tempfile"), os = py::module_::import("os");
    py::object nimbusModule = py::module_::import("nimbus");
    if (!py::hasattr(nimbusModule, "_grid_dir")) {
        py::object dir = tempfile.attr("mkdtemp")(py::arg("prefix") = "nimbus-grids-");
        py::module_::import("atexit").attr("register")(py::module_::import("shutil").attr("rmtree"), dir, true);
        nimbusModule.attr("_grid_dir") = dir;
    }
    std::string path = py::str(
        os.attr("path").attr("join")(nimbusModule.attr("_grid_dir"), "grids" + std::to_string(counter++) + ".vdb"));
    py::list list;
    for (auto item : grids)
        list.append(item.second);
    py::module_::import("pyopenvdb").attr("write")(path, py::arg("grids") = list);
    return path;
}

PyVolume volumeFromGrids(const py::dict& roles, const py::dict& params)
{
    // Unnamed grids get their role as name (on a copy: the caller's grid is not renamed).
    py::dict named;
    py::dict gridNames;
    for (auto item : roles) {
        std::string role = py::str(item.first);
        py::object grid = py::reinterpret_borrow<py::object>(item.second);
        std::string name = py::str(grid.attr("name"));
        if (name.empty()) {
            grid = grid.attr("deepCopy")();
            grid.attr("name") = role;
            name = role;
        }
        named[py::str(role)] = grid;
        gridNames[py::str(role)] = name;
    }
    NimbusVolume h;
    checkPy(nimbus_volume_create("vdb", &h));
    PyVolume v = adopt<PyVolume>(h);
    setValue(h, "source.file", py::str(gridFile(named)));
    setValue(h, "source.grids", gridNames);
    setMany(h, params);
    return v;
}

// ---- frames and AOVs ----------------------------------------------------------------------

struct PyFrame {
    Frame frame;
};

// One AOV: a read-only float32 buffer (buffer protocol) that keeps its frame alive.
struct PyAov {
    Frame frame;
    NimbusAov aov;
};

py::buffer_info aovBuffer(const PyAov& a)
{
    const NimbusAov& v = a.aov;
    std::vector<py::ssize_t> shape = {v.height, v.width}, strides = {py::ssize_t(sizeof(float)) * v.width * v.channels,
                                                                     py::ssize_t(sizeof(float)) * v.channels};
    if (v.channels > 1) {
        shape.push_back(v.channels);
        strides.push_back(sizeof(float));
    }
    return py::buffer_info(const_cast<float*>(v.pixels), sizeof(float), py::format_descriptor<float>::format(),
                           py::ssize_t(shape.size()), shape, strides, /*readonly=*/true);
}

// A numpy view of the AOV (no copy): (height, width, channels), or (height, width) for data.
py::array aovArray(const PyFrame& f, const NimbusAov& aov)
{
    py::object holder = py::cast(PyAov{f.frame, aov});
    py::buffer_info info = aovBuffer(holder.cast<const PyAov&>());
    py::array a(py::dtype::of<float>(), info.shape, info.strides, info.ptr, holder);
    a.attr("setflags")(py::arg("write") = false);
    return a;
}

// ---- sessions -----------------------------------------------------------------------------

struct PySession {
    NimbusSession handle = NIMBUS_NULL_HANDLE;
    py::object progress;  // callable or None
    py::object error;     // an exception the callback raised, re-raised after the render

    PySession(const PyScene& scene, py::object callback) : progress(std::move(callback))
    {
        checkPy(nimbus_session_create(scene.handle.get(), &handle));
        if (!progress.is_none())
            checkPy(nimbus_session_set_progress_callback(handle, &PySession::trampoline, this));
    }
    ~PySession()
    {
        // Releasing waits for a running render, whose callback needs the GIL.
        py::gil_scoped_release nogil;
        nimbus_release(handle);
    }
    PySession(const PySession&) = delete;
    PySession& operator=(const PySession&) = delete;

    static int trampoline(float fraction, void* user)
    {
        auto* self = static_cast<PySession*>(user);
        py::gil_scoped_acquire gil;
        try {
            py::object r = self->progress(fraction);
            return r.is_none() || r.cast<bool>() ? 1 : 0;
        } catch (py::error_already_set& e) {
            self->error = e.value();
            return 0;
        }
    }

    void finish(NimbusStatus status)
    {
        if (status == NIMBUS_OK)
            return;
        std::string message = nimbus_last_error();
        if (!error.is_none()) {
            py::object e = error;
            error = py::none();
            PyErr_SetObject(reinterpret_cast<PyObject*>(Py_TYPE(e.ptr())), e.ptr());
            throw py::error_already_set();
        }
        raise(status, message);
    }

    PyFrame frame() const
    {
        NimbusFrame f;
        checkPy(nimbus_session_frame(handle, &f));
        return PyFrame{Frame(Handle::adopt(f))};
    }

    PyFrame render()
    {
        error = py::none();
        NimbusStatus s;
        std::string message;
        {
            py::gil_scoped_release nogil;
            s = nimbus_session_render(handle);
        }
        finish(s);
        return frame();
    }
    void start()
    {
        error = py::none();
        checkPy(nimbus_session_start(handle));
    }
    bool wait(double timeout)
    {
        NimbusStatus s;
        {
            py::gil_scoped_release nogil;
            s = nimbus_session_wait(handle, timeout);
        }
        if (s == NIMBUS_ERROR_TIMEOUT)
            return false;
        finish(s);
        return true;
    }
    void cancel() { checkPy(nimbus_session_cancel(handle)); }
    py::tuple state() const
    {
        NimbusSessionState st;
        float progressValue = 0;
        checkPy(nimbus_session_state(handle, &st, &progressValue));
        const char* names[] = {"idle", "running", "finished", "failed"};
        return py::make_tuple(names[int(st)], progressValue);
    }
};

PyScene sceneFromJson(const std::string& text, const std::string& baseDir)
{
    NimbusScene h;
    checkPy(nimbus_scene_load_json(text.c_str(), baseDir.empty() ? nullptr : baseDir.c_str(), &h));
    return adopt<PyScene>(h);
}

std::string sceneJson(const PyScene& s)
{
    size_t n = 0;
    NimbusStatus st = nimbus_scene_to_json(s.handle.get(), nullptr, 0, &n);
    if (st != NIMBUS_ERROR_BUFFER_TOO_SMALL)
        checkPy(st);
    std::string text(n + 1, '\0');
    checkPy(nimbus_scene_to_json(s.handle.get(), &text[0], text.size(), &n));
    text.resize(n);
    return text;
}

template <class T>
void bindParams(py::class_<T>& c)
{
    c.def("set", &T::set, py::arg("name"), py::arg("value"),
          "Sets a parameter by its scene-format key path ('medium.phase.g').")
        .def("__setitem__", &T::set)
        .def("update", [](T& self, const py::dict& d) { setMany(self.handle.get(), d); })
        .def("unset", &T::unset, "Gives a parameter back its default.")
        .def("commit", &T::commit)
        .def_property_readonly("handle", [](const T& self) { return self.handle.get(); });
}

}  // namespace

PYBIND11_MODULE(nimbus, m)
{
    m.doc() = "nimbus volume renderer: scenes, rendering and AOVs (docs/embedding.md)";
    m.attr("__version__") = nimbus_version();
    m.attr("ABI_VERSION") = nimbus_abi_version();

    gError = PyErr_NewExceptionWithDoc("nimbus.Error",
                                       "A nimbus call failed; .status names the C status (NIMBUS_ERROR_...).",
                                       PyExc_RuntimeError, nullptr);
    py::tuple inputBases = py::make_tuple(py::reinterpret_borrow<py::object>(gError),
                                          py::reinterpret_borrow<py::object>(PyExc_ValueError));
    gInputError = PyErr_NewExceptionWithDoc(
        "nimbus.InputError", "Bad input: unknown parameter, wrong type, value out of range, missing file.",
        inputBases.ptr(), nullptr);
    gCancelled = PyErr_NewExceptionWithDoc("nimbus.Cancelled", "The render was cancelled.", gError, nullptr);
    if (!gError || !gInputError || !gCancelled)
        throw py::error_already_set();
    m.attr("Error") = py::reinterpret_borrow<py::object>(gError);
    m.attr("InputError") = py::reinterpret_borrow<py::object>(gInputError);
    m.attr("Cancelled") = py::reinterpret_borrow<py::object>(gCancelled);

    auto camera = py::class_<PyCamera>(m, "Camera", "The view; parameters as the scene format's camera object.")
                      .def(py::init([](py::kwargs kw) {
                          NimbusCamera h;
                          checkPy(nimbus_camera_create(&h));
                          PyCamera c = adopt<PyCamera>(h);
                          setMany(h, kw);
                          return c;
                      }));
    bindParams(camera);

    auto light = py::class_<PyLight>(m, "Light", "A light: Light('distant', irradiance=3, direction=(0,-1,0)).")
                     .def(py::init([](const std::string& type, py::dict params, py::kwargs kw) {
                              NimbusLight h;
                              checkPy(nimbus_light_create(type.c_str(), &h));
                              PyLight l = adopt<PyLight>(h);
                              setMany(h, params);
                              setMany(h, kw);
                              return l;
                          }),
                          py::arg("type"), py::arg("params") = py::dict());
    bindParams(light);

    auto volume =
        py::class_<PyVolume>(m, "Volume",
                             "A volume: Volume('vdb', {'source.file': 'smoke.vdb', 'medium.sigma_s': 2}), "
                             "Volume('procedural', {'source.generator': 'sphere'}), or Volume.from_grid(grid).")
            .def(py::init([](const std::string& sourceType, py::dict params) {
                     NimbusVolume h;
                     checkPy(nimbus_volume_create(sourceType.c_str(), &h));
                     PyVolume v = adopt<PyVolume>(h);
                     setMany(h, params);
                     return v;
                 }),
                 py::arg("source_type"), py::arg("params") = py::dict())
            .def_static(
                "from_grid",
                [](py::object grid, py::dict params) {
                    py::dict roles;
                    roles["density"] = grid;
                    return volumeFromGrids(roles, params);
                },
                py::arg("grid"), py::arg("params") = py::dict(),
                "A vdb volume from a pyopenvdb FloatGrid (written to a temporary .vdb file).")
            .def_static("from_grids", &volumeFromGrids, py::arg("grids"), py::arg("params") = py::dict(),
                        "A vdb volume from {role: pyopenvdb grid} (density, temperature, flame, Cd, vel).");
    bindParams(volume);

    auto scene =
        py::class_<PyScene>(m, "Scene", "A scene: camera, lights, volumes and its own render/output keys.")
            .def(py::init([]() {
                NimbusScene h;
                checkPy(nimbus_scene_create(&h));
                return adopt<PyScene>(h);
            }))
            .def_property(
                "camera",
                [](const PyScene& s) {
                    NimbusCamera h;
                    checkPy(nimbus_scene_get_camera(s.handle.get(), &h));
                    return adopt<PyCamera>(h);
                },
                [](PyScene& s, const PyCamera& c) { checkPy(nimbus_scene_set_camera(s.handle.get(), c.handle.get())); })
            .def("add",
                 [](PyScene& s, const PyLight& l) { checkPy(nimbus_scene_add_light(s.handle.get(), l.handle.get())); })
            .def("add", [](PyScene& s,
                           const PyVolume& v) { checkPy(nimbus_scene_add_volume(s.handle.get(), v.handle.get())); })
            .def("remove", [](PyScene& s,
                              const PyLight& l) { checkPy(nimbus_scene_remove_light(s.handle.get(), l.handle.get())); })
            .def("remove",
                 [](PyScene& s, const PyVolume& v) {
                     checkPy(nimbus_scene_remove_volume(s.handle.get(), v.handle.get()));
                 })
            .def_property_readonly("lights",
                                   [](const PyScene& s) {
                                       size_t n;
                                       checkPy(nimbus_scene_light_count(s.handle.get(), &n));
                                       std::vector<PyLight> out;
                                       for (size_t i = 0; i < n; ++i) {
                                           NimbusLight h;
                                           checkPy(nimbus_scene_get_light(s.handle.get(), i, &h));
                                           out.push_back(adopt<PyLight>(h));
                                       }
                                       return out;
                                   })
            .def_property_readonly("volumes",
                                   [](const PyScene& s) {
                                       size_t n;
                                       checkPy(nimbus_scene_volume_count(s.handle.get(), &n));
                                       std::vector<PyVolume> out;
                                       for (size_t i = 0; i < n; ++i) {
                                           NimbusVolume h;
                                           checkPy(nimbus_scene_get_volume(s.handle.get(), i, &h));
                                           out.push_back(adopt<PyVolume>(h));
                                       }
                                       return out;
                                   })
            .def("to_json", &sceneJson, "The committed scene as the JSON `nimbus render` reads.")
            .def("to_dict", [](const PyScene& s) { return py::module_::import("json").attr("loads")(sceneJson(s)); });
    bindParams(scene);

    py::class_<PyAov>(m, "Aov", py::buffer_protocol(), "One AOV buffer (read-only float32, buffer protocol).")
        .def_buffer([](PyAov& a) { return aovBuffer(a); })
        .def_property_readonly("name", [](const PyAov& a) { return std::string(a.aov.name); })
        .def_property_readonly("channels", [](const PyAov& a) { return a.aov.channels; })
        .def_property_readonly("is_data", [](const PyAov& a) { return a.aov.is_data != 0; })
        .def_property_readonly("data_window",
                               [](const PyAov& a) { return py::make_tuple(a.aov.x0, a.aov.y0, a.aov.x1, a.aov.y1); });

    py::class_<PyFrame>(m, "Frame", "A finished render: frame['beauty'] is a float32 numpy view, no copy.")
        .def("__getitem__",
             [](const PyFrame& f, const std::string& name) {
                 NimbusAov a;
                 checkPy(nimbus_frame_find_aov(f.frame.get(), name.c_str(), &a));
                 return aovArray(f, a);
             })
        .def("__contains__",
             [](const PyFrame& f, const std::string& name) {
                 NimbusAov a;
                 return nimbus_frame_find_aov(f.frame.get(), name.c_str(), &a) == NIMBUS_OK;
             })
        .def("aov",
             [](const PyFrame& f, const std::string& name) {
                 NimbusAov a;
                 checkPy(nimbus_frame_find_aov(f.frame.get(), name.c_str(), &a));
                 return PyAov{f.frame, a};
             })
        .def("keys",
             [](const PyFrame& f) {
                 std::vector<std::string> names;
                 for (const NimbusAov& a : f.frame.aovs())
                     names.push_back(a.name);
                 return names;
             })
        .def("aovs",
             [](const PyFrame& f) {
                 py::dict d;
                 for (const NimbusAov& a : f.frame.aovs())
                     d[py::str(a.name)] = aovArray(f, a);
                 return d;
             })
        .def_property_readonly("seconds", [](const PyFrame& f) { return f.frame.seconds(); })
        .def(
            "write_outputs", [](const PyFrame& f) { checkPy(nimbus_frame_write_outputs(f.frame.get())); },
            "Writes the scene's output.file (EXR) and output.preview as `nimbus render` does.");

    py::class_<PySession>(m, "Session", "Renders a scene's committed snapshot, in the foreground or background.")
        .def(py::init<const PyScene&, py::object>(), py::arg("scene"), py::arg("progress") = py::none())
        .def("render", &PySession::render, "Renders (GIL released) and returns the Frame.")
        .def("start", &PySession::start, "Starts a background render.")
        .def("wait", &PySession::wait, py::arg("timeout") = -1.0,
             "Waits for a background render: True when finished, False on timeout; raises if it failed.")
        .def("cancel", &PySession::cancel)
        .def_property_readonly("state", &PySession::state,
                               "(state, progress): 'idle', 'running', 'finished', 'failed'.")
        .def_property_readonly("frame", &PySession::frame);

    m.def(
        "load",
        [](py::object path) {
            std::string p = py::str(py::module_::import("os").attr("fspath")(path));
            NimbusScene h;
            checkPy(nimbus_scene_load_file(p.c_str(), &h));
            return adopt<PyScene>(h);
        },
        py::arg("path"), "Loads and commits a JSON scene file.");
    m.def(
        "load_dict",
        [](const py::dict& d, py::object baseDir) {
            std::string base =
                baseDir.is_none() ? "" : std::string(py::str(py::module_::import("os").attr("fspath")(baseDir)));
            return sceneFromJson(toJsonText(d), base);
        },
        py::arg("scene"), py::arg("base_dir") = py::none(),
        "Loads and commits a scene given as a dict in the JSON format; base_dir anchors relative vdb paths.");
    m.def(
        "render",
        [](PyScene& scene, py::object progress, bool commit) {
            if (commit)
                scene.commit();
            PySession session(scene, progress);
            return session.render();
        },
        py::arg("scene"), py::arg("progress") = py::none(), py::arg("commit") = true,
        "Commits (unless commit=False) and renders; progress(fraction) may return False to cancel.");
}
