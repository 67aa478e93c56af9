#include "ensemble/results_file.hpp"

#include <hdf5.h>
#include <mpi.h>

#include <cerrno>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <limits>
#include <utility>

namespace ringsim {

std::string fnv1a_hex(const std::string& text) {
  // FNV-1a, 64-bit offset basis and prime (Fowler, Noll, Vo; IETF draft
  // draft-eastlake-fnv).
  std::uint64_t h = 14695981039346656037ull;
  for (unsigned char c : text) {
    h ^= c;
    h *= 1099511628211ull;
  }
  char buf[17];
  std::snprintf(buf, sizeof buf, "%016llx", static_cast<unsigned long long>(h));
  return buf;
}

namespace {

// ---- Error handling: every HDF5 call is checked; messages name the file and
// the operation, plus the innermost HDF5 error description. ----------------

std::string hdf5_error_detail() {
  std::string detail;
  H5Ewalk2(
      H5E_DEFAULT, H5E_WALK_UPWARD,
      [](unsigned, const H5E_error2_t* e, void* out) -> herr_t {
        auto* s = static_cast<std::string*>(out);
        if (s->empty() && e->desc) *s = e->desc;
        return 0;
      },
      &detail);
  H5Eclear2(H5E_DEFAULT);
  // POSIX write failures carry the system's message inside a long record.
  const std::string key = "error message = '";
  const std::size_t at = detail.find(key);
  if (at != std::string::npos) {
    const std::size_t end = detail.find('\'', at + key.size());
    return detail.substr(at + key.size(), end == std::string::npos ? std::string::npos : end - at - key.size());
  }
  return detail;
}

struct Ctx {
  std::string path;
  [[noreturn]] void fail(const std::string& what) const {
    std::string detail = hdf5_error_detail();
    throw ResultsFileError(path + ": " + what + (detail.empty() ? "" : " (HDF5: " + detail + ")"));
  }
  hid_t ok(hid_t id, const char* what) const {
    if (id < 0) fail(what);
    return id;
  }
  void ok_status(herr_t st, const char* what) const {
    if (st < 0) fail(what);
  }
};

void silence_hdf5() {
  static const bool once = [] {
    H5Eset_auto2(H5E_DEFAULT, nullptr, nullptr);
    return true;
  }();
  (void)once;
}

// RAII owner of one HDF5 identifier.
class Handle {
 public:
  using Closer = herr_t (*)(hid_t);
  Handle() = default;
  Handle(hid_t id, Closer closer) : id_(id), closer_(closer) {}
  ~Handle() { reset(); }
  Handle(Handle&& o) noexcept : id_(std::exchange(o.id_, -1)), closer_(o.closer_) {}
  Handle& operator=(Handle&& o) noexcept {
    if (this != &o) {
      reset();
      id_ = std::exchange(o.id_, -1);
      closer_ = o.closer_;
    }
    return *this;
  }
  Handle(const Handle&) = delete;
  Handle& operator=(const Handle&) = delete;
  hid_t get() const { return id_; }
  // Closes now and reports failure (a close can be the write that fails).
  herr_t close() { return id_ >= 0 ? closer_(std::exchange(id_, -1)) : 0; }
  void reset() {
    if (id_ >= 0) closer_(std::exchange(id_, -1));
  }

 private:
  hid_t id_ = -1;
  Closer closer_ = nullptr;
};

Handle type_handle(const Ctx& c, hid_t id, const char* what) { return Handle(c.ok(id, what), H5Tclose); }
Handle space_handle(const Ctx& c, hid_t id, const char* what) { return Handle(c.ok(id, what), H5Sclose); }
Handle plist_handle(const Ctx& c, hid_t id, const char* what) { return Handle(c.ok(id, what), H5Pclose); }

Handle fixed_string(const Ctx& c, std::size_t size) {
  Handle t = type_handle(c, H5Tcopy(H5T_C_S1), "string type");
  c.ok_status(H5Tset_size(t.get(), size), "string type size");
  c.ok_status(H5Tset_strpad(t.get(), H5T_STR_NULLTERM), "string padding");
  return t;
}

#define RINGSIM_FIELD(name, type) c.ok_status(H5Tinsert(t.get(), #name, HOFFSET(ReplicateRecord, name), type), #name)

// The compound type of /replicates (memory and file: native layout).
Handle record_type(const Ctx& c) {
  Handle t = type_handle(c, H5Tcreate(H5T_COMPOUND, sizeof(ReplicateRecord)), "record type");
  Handle term = fixed_string(c, sizeof(ReplicateRecord::termination));
  Handle err = fixed_string(c, sizeof(ReplicateRecord::error));
  RINGSIM_FIELD(id, H5T_NATIVE_UINT64);
  RINGSIM_FIELD(seed, H5T_NATIVE_UINT64);
  RINGSIM_FIELD(status, H5T_NATIVE_INT8);
  RINGSIM_FIELD(termination, term.get());
  RINGSIM_FIELD(error, err.get());
  RINGSIM_FIELD(t_end, H5T_NATIVE_DOUBLE);
  RINGSIM_FIELD(events, H5T_NATIVE_UINT64);
  RINGSIM_FIELD(wall_seconds, H5T_NATIVE_DOUBLE);
  RINGSIM_FIELD(N_t, H5T_NATIVE_INT32);
  RINGSIM_FIELD(N_tar, H5T_NATIVE_INT32);
  RINGSIM_FIELD(N_viab, H5T_NATIVE_INT32);
  RINGSIM_FIELD(N_nv1, H5T_NATIVE_INT32);
  RINGSIM_FIELD(N_nv2, H5T_NATIVE_INT32);
  RINGSIM_FIELD(N_nv3, H5T_NATIVE_INT32);
  RINGSIM_FIELD(N_cyc, H5T_NATIVE_INT32);
  RINGSIM_FIELD(Phi_obj, H5T_NATIVE_DOUBLE);
  RINGSIM_FIELD(Phi_viab, H5T_NATIVE_DOUBLE);
  RINGSIM_FIELD(S4, H5T_NATIVE_DOUBLE);
  RINGSIM_FIELD(M_mono, H5T_NATIVE_DOUBLE);
  RINGSIM_FIELD(M_mono_S, H5T_NATIVE_DOUBLE);
  RINGSIM_FIELD(M_mono_L, H5T_NATIVE_DOUBLE);
  RINGSIM_FIELD(tau_tar, H5T_NATIVE_DOUBLE);
  RINGSIM_FIELD(tau_tar_censored, H5T_NATIVE_INT8);
  RINGSIM_FIELD(ring_2, H5T_NATIVE_INT32);
  // The histogram as scalar columns ring_3 .. ring_12 (pandas-friendly).
  for (int k = 0; k < ReplicateRecord::kRingBins; ++k) {
    const std::string name = "ring_" + std::to_string(k + 3);
    c.ok_status(H5Tinsert(t.get(), name.c_str(), HOFFSET(ReplicateRecord, ring) + k * sizeof(std::int32_t),
                          H5T_NATIVE_INT32),
                "ring column");
  }
  RINGSIM_FIELD(ring_over, H5T_NATIVE_INT32);
  RINGSIM_FIELD(collisions, H5T_NATIVE_UINT64);
  RINGSIM_FIELD(captures, H5T_NATIVE_UINT64);
  RINGSIM_FIELD(bonds, H5T_NATIVE_INT32);
  RINGSIM_FIELD(closure_bonds, H5T_NATIVE_INT32);
  RINGSIM_FIELD(mser_truncation, H5T_NATIVE_INT64);
  RINGSIM_FIELD(packing_fraction, H5T_NATIVE_DOUBLE);
  RINGSIM_FIELD(mixing, H5T_NATIVE_DOUBLE);
  RINGSIM_FIELD(failed_slices, H5T_NATIVE_INT64);
  RINGSIM_FIELD(released_held_rows, H5T_NATIVE_INT64);
  RINGSIM_FIELD(readmitted_held_rows, H5T_NATIVE_INT64);
  RINGSIM_FIELD(max_residual_after_projection, H5T_NATIVE_DOUBLE);
  RINGSIM_FIELD(max_cut_residual, H5T_NATIVE_DOUBLE);
  RINGSIM_FIELD(max_released_residual, H5T_NATIVE_DOUBLE);
  RINGSIM_FIELD(max_projection, H5T_NATIVE_DOUBLE);
  RINGSIM_FIELD(end_rigid_bodies, H5T_NATIVE_INT32);
  RINGSIM_FIELD(end_articulated_bodies, H5T_NATIVE_INT32);
  return t;
}
#undef RINGSIM_FIELD

// One row of /summary.
struct SummaryRow {
  char name[24];
  double mean, ci95, std;
  std::int32_t n, n_undefined, n_censored;
};

Handle summary_type(const Ctx& c) {
  Handle t = type_handle(c, H5Tcreate(H5T_COMPOUND, sizeof(SummaryRow)), "summary type");
  Handle name = fixed_string(c, sizeof(SummaryRow::name));
  c.ok_status(H5Tinsert(t.get(), "name", HOFFSET(SummaryRow, name), name.get()), "name");
  c.ok_status(H5Tinsert(t.get(), "mean", HOFFSET(SummaryRow, mean), H5T_NATIVE_DOUBLE), "mean");
  c.ok_status(H5Tinsert(t.get(), "ci95", HOFFSET(SummaryRow, ci95), H5T_NATIVE_DOUBLE), "ci95");
  c.ok_status(H5Tinsert(t.get(), "std", HOFFSET(SummaryRow, std), H5T_NATIVE_DOUBLE), "std");
  c.ok_status(H5Tinsert(t.get(), "n", HOFFSET(SummaryRow, n), H5T_NATIVE_INT32), "n");
  c.ok_status(H5Tinsert(t.get(), "n_undefined", HOFFSET(SummaryRow, n_undefined), H5T_NATIVE_INT32), "n_undefined");
  c.ok_status(H5Tinsert(t.get(), "n_censored", HOFFSET(SummaryRow, n_censored), H5T_NATIVE_INT32), "n_censored");
  return t;
}

// ---- Attributes ------------------------------------------------------------

void write_attr(const Ctx& c, hid_t obj, const char* name, const std::string& value) {
  Handle t = fixed_string(c, value.size() + 1);
  Handle s = space_handle(c, H5Screate(H5S_SCALAR), "scalar space");
  Handle a(c.ok(H5Acreate2(obj, name, t.get(), s.get(), H5P_DEFAULT, H5P_DEFAULT), name), H5Aclose);
  c.ok_status(H5Awrite(a.get(), t.get(), value.c_str()), name);
}

template <class T>
hid_t native_type();
template <>
hid_t native_type<std::int64_t>() { return H5T_NATIVE_INT64; }
template <>
hid_t native_type<std::uint64_t>() { return H5T_NATIVE_UINT64; }
template <>
hid_t native_type<double>() { return H5T_NATIVE_DOUBLE; }

template <class T>
void write_attr(const Ctx& c, hid_t obj, const char* name, T value) {
  Handle s = space_handle(c, H5Screate(H5S_SCALAR), "scalar space");
  Handle a(c.ok(H5Acreate2(obj, name, native_type<T>(), s.get(), H5P_DEFAULT, H5P_DEFAULT), name), H5Aclose);
  c.ok_status(H5Awrite(a.get(), native_type<T>(), &value), name);
}

std::string read_string_attr(const Ctx& c, hid_t obj, const char* name) {
  Handle a(c.ok(H5Aopen(obj, name, H5P_DEFAULT), name), H5Aclose);
  Handle ft = type_handle(c, H5Aget_type(a.get()), name);
  if (H5Tget_class(ft.get()) != H5T_STRING) c.fail(std::string("attribute ") + name + " is not a string");
  if (H5Tis_variable_str(ft.get()) > 0) c.fail(std::string("attribute ") + name + " is a variable-length string");
  const std::size_t size = H5Tget_size(ft.get());
  std::string buf(size + 1, '\0');
  Handle mt = fixed_string(c, size + 1);
  c.ok_status(H5Aread(a.get(), mt.get(), buf.data()), name);
  buf.resize(std::strlen(buf.c_str()));
  return buf;
}

template <class T>
T read_attr(const Ctx& c, hid_t obj, const char* name) {
  Handle a(c.ok(H5Aopen(obj, name, H5P_DEFAULT), name), H5Aclose);
  T value{};
  c.ok_status(H5Aread(a.get(), native_type<T>(), &value), name);
  return value;
}

void write_provenance(const Ctx& c, hid_t file, const Provenance& p) {
  write_attr(c, file, "program", p.program);
  write_attr(c, file, "version", p.version);
  write_attr(c, file, "scenario", p.scenario);
  write_attr(c, file, "scenario_file", p.scenario_file);
  write_attr(c, file, "overrides", p.overrides);
  write_attr(c, file, "config_toml", p.config_toml);
  write_attr(c, file, "config_hash", p.config_hash);
  write_attr(c, file, "base_seed", p.base_seed);
  write_attr(c, file, "replicates", p.replicates);
  write_attr(c, file, "ranks", p.ranks);
  write_attr(c, file, "host", p.host);
  write_attr(c, file, "start_time", p.start_time);
  write_attr(c, file, "end_time", p.end_time);
  write_attr(c, file, "complete", p.complete);
  write_attr(c, file, "series_length", p.series_length);
  write_attr(c, file, "runs", p.runs);
}

Provenance read_provenance(const Ctx& c, hid_t file) {
  Provenance p;
  if (H5Aexists(file, "program") <= 0 || read_string_attr(c, file, "program") != "ringsim")
    throw ResultsFileError(c.path + ": not a ringsim result file (no attribute program = \"ringsim\")");
  p.version = read_string_attr(c, file, "version");
  p.scenario = read_string_attr(c, file, "scenario");
  p.scenario_file = read_string_attr(c, file, "scenario_file");
  p.overrides = read_string_attr(c, file, "overrides");
  p.config_toml = read_string_attr(c, file, "config_toml");
  p.config_hash = read_string_attr(c, file, "config_hash");
  p.base_seed = read_attr<std::uint64_t>(c, file, "base_seed");
  p.replicates = read_attr<std::uint64_t>(c, file, "replicates");
  p.ranks = read_attr<std::int64_t>(c, file, "ranks");
  p.host = read_string_attr(c, file, "host");
  p.start_time = read_string_attr(c, file, "start_time");
  p.end_time = read_string_attr(c, file, "end_time");
  p.complete = read_attr<std::int64_t>(c, file, "complete");
  p.series_length = read_attr<std::int64_t>(c, file, "series_length");
  p.runs = read_attr<std::int64_t>(c, file, "runs");
  return p;
}

// ---- Files -----------------------------------------------------------------

// Writers use the MPI-IO driver (on MPI_COMM_SELF) inside an MPI program:
// a file flushed through it stays readable after a kill (DESIGN.md, measured).
// Whole files written before a rename use the POSIX driver: they are closed
// before anyone relies on them, and a failed write (disk full) through
// MPI-IO leaves HDF5 state that crashes MPI_Finalize (seen with 1.10.8).
Handle access_plist(const Ctx& c, bool mpio) {
  Handle fapl = plist_handle(c, H5Pcreate(H5P_FILE_ACCESS), "file access list");
  int mpi_on = 0, mpi_off = 0;
  MPI_Initialized(&mpi_on);
  MPI_Finalized(&mpi_off);
  if (mpio && mpi_on && !mpi_off)
    c.ok_status(H5Pset_fapl_mpio(fapl.get(), MPI_COMM_SELF, MPI_INFO_NULL), "MPI-IO driver");
  return fapl;
}

// A dataset allocated and filled at creation (contiguous), so later row
// writes never change metadata.
Handle create_dataset(const Ctx& c, hid_t loc, const char* name, hid_t type, const std::vector<hsize_t>& dims,
                      const void* fill) {
  Handle space = space_handle(c, H5Screate_simple(static_cast<int>(dims.size()), dims.data(), nullptr), name);
  Handle dcpl = plist_handle(c, H5Pcreate(H5P_DATASET_CREATE), name);
  c.ok_status(H5Pset_alloc_time(dcpl.get(), H5D_ALLOC_TIME_EARLY), name);
  if (fill) {
    c.ok_status(H5Pset_fill_value(dcpl.get(), type, fill), name);
    c.ok_status(H5Pset_fill_time(dcpl.get(), H5D_FILL_TIME_ALLOC), name);
  }
  return Handle(c.ok(H5Dcreate2(loc, name, type, space.get(), H5P_DEFAULT, dcpl.get(), H5P_DEFAULT), name), H5Dclose);
}

void write_all(const Ctx& c, hid_t dset, hid_t type, const void* data, const char* what) {
  c.ok_status(H5Dwrite(dset, type, H5S_ALL, H5S_ALL, H5P_DEFAULT, data), what);
}

void write_summary(const Ctx& c, hid_t file, const EnsembleSummary& s) {
  std::vector<SummaryRow> rows;
  for (const ObservableSummary& o : s.rows) {
    SummaryRow r{};
    std::snprintf(r.name, sizeof r.name, "%s", o.name.c_str());
    r.mean = o.mean;
    r.ci95 = o.ci95;
    r.std = o.std;
    r.n = o.n;
    r.n_undefined = o.n_undefined;
    r.n_censored = o.n_censored;
    rows.push_back(r);
  }
  Handle t = summary_type(c);
  Handle d = create_dataset(c, file, "summary", t.get(), {static_cast<hsize_t>(rows.size())}, nullptr);
  write_all(c, d.get(), t.get(), rows.data(), "write /summary");
  write_attr(c, d.get(), "S4_pooled", s.S4_pooled);
  write_attr(c, d.get(), "S4_pooled_ci95", s.S4_pooled_ci95);
  write_attr(c, d.get(), "tau_tar_km_median", s.tau_tar_km_median);
  write_attr(c, d.get(), "n_total", static_cast<std::int64_t>(s.n_total));
  write_attr(c, d.get(), "n_ok", static_cast<std::int64_t>(s.n_ok));
  write_attr(c, d.get(), "n_failed", static_cast<std::int64_t>(s.n_failed));
  write_attr(c, d.get(), "n_pending", static_cast<std::int64_t>(s.n_pending));
}

// Creates a complete file at `path` (truncating) and flushes it.
Handle write_file(const Ctx& c, const ResultsContent& content, const EnsembleSummary* summary) {
  silence_hdf5();
  const Provenance& p = content.provenance;
  Handle fapl = access_plist(c, false);
  Handle file(c.ok(H5Fcreate(c.path.c_str(), H5F_ACC_TRUNC, H5P_DEFAULT, fapl.get()), "cannot create file"), H5Fclose);
  write_provenance(c, file.get(), p);
  Handle rt = record_type(c);
  // Filled at allocation although every row is written next: a full disk
  // then fails inside H5Dcreate, which HDF5 1.10.8 recovers from; a failed
  // H5Dwrite leaves state that crashes at exit (FullDiskIsAClearError... test).
  const ReplicateRecord pending{};
  Handle rows = create_dataset(c, file.get(), "replicates", rt.get(), {p.replicates}, &pending);
  write_all(c, rows.get(), rt.get(), content.records.data(), "write /replicates");
  if (p.series_length > 0) {
    Handle g(c.ok(H5Gcreate2(file.get(), "series", H5P_DEFAULT, H5P_DEFAULT, H5P_DEFAULT), "group /series"), H5Gclose);
    const float nan = std::numeric_limits<float>::quiet_NaN();
    Handle s = create_dataset(c, g.get(), "N_t", H5T_NATIVE_FLOAT,
                              {p.replicates, static_cast<hsize_t>(p.series_length)}, &nan);
    if (!content.series.empty()) write_all(c, s.get(), H5T_NATIVE_FLOAT, content.series.data(), "write /series/N_t");
    write_attr(c, s.get(), "sample_interval_note",
               std::string("row r = replicate r; column k = N_t at k * run.sample_interval; NaN after the end"));
  }
  if (summary) write_summary(c, file.get(), *summary);
  c.ok_status(H5Fflush(file.get(), H5F_SCOPE_GLOBAL), "flush (disk full?)");
  return file;
}

void remove_quietly(const std::string& path) { std::remove(path.c_str()); }

// Creates `path` through `path`.tmp and a rename: the old file (if any)
// survives every failure.
Handle write_file_atomically(const std::string& path, const ResultsContent& content, const EnsembleSummary* summary,
                             bool keep_open) {
  const std::string tmp = path + ".tmp";
  Ctx c{tmp};
  // The plain reason (missing directory, permissions, full disk) before
  // HDF5 and MPI-IO wrap it.
  if (FILE* probe = std::fopen(tmp.c_str(), "wb")) {
    std::fclose(probe);
  } else {
    throw ResultsFileError("cannot create " + tmp + ": " + std::strerror(errno));
  }
  try {
    Handle file = write_file(c, content, summary);
    if (file.close() < 0) c.fail("close (disk full?)");
  } catch (...) {
    remove_quietly(tmp);
    throw;
  }
  if (std::rename(tmp.c_str(), path.c_str()) != 0) {
    remove_quietly(tmp);
    throw ResultsFileError(path + ": cannot rename " + tmp + " over it: " + std::strerror(errno));
  }
  if (!keep_open) return Handle();
  Ctx co{path};
  Handle fapl = access_plist(co, true);
  return Handle(co.ok(H5Fopen(path.c_str(), H5F_ACC_RDWR, fapl.get()), "cannot reopen file"), H5Fclose);
}

}  // namespace

// ---- ResultsWriter -----------------------------------------------------------

struct ResultsWriter::Impl {
  Ctx c;
  Handle file;
  Handle rows;
  Handle series;
  Handle record_t;
  std::int64_t series_length = 0;
  hsize_t replicates = 0;
};

ResultsWriter::ResultsWriter(std::unique_ptr<Impl> impl) : impl_(std::move(impl)) {}
ResultsWriter::~ResultsWriter() = default;

namespace {

std::unique_ptr<ResultsWriter::Impl> open_datasets(const std::string& path, Handle file, const Provenance& p) {
  auto impl = std::make_unique<ResultsWriter::Impl>();
  impl->c.path = path;
  const Ctx& c = impl->c;
  impl->rows = Handle(c.ok(H5Dopen2(file.get(), "replicates", H5P_DEFAULT), "open /replicates"), H5Dclose);
  if (p.series_length > 0)
    impl->series = Handle(c.ok(H5Dopen2(file.get(), "series/N_t", H5P_DEFAULT), "open /series/N_t"), H5Dclose);
  impl->record_t = record_type(c);
  impl->series_length = p.series_length;
  impl->replicates = p.replicates;
  impl->file = std::move(file);
  return impl;
}

std::vector<ReplicateRecord> pending_rows(const Provenance& p) {
  std::vector<ReplicateRecord> rows;
  rows.reserve(p.replicates);
  for (std::uint64_t r = 0; r < p.replicates; ++r)
    rows.push_back(blank_record(r, p.base_seed, RecordStatus::Pending, "pending"));
  return rows;
}

}  // namespace

std::unique_ptr<ResultsWriter> ResultsWriter::create(const std::string& path, const Provenance& prov) {
  if (prov.replicates == 0) throw ResultsFileError(path + ": replicates must be >= 1");
  ResultsContent content{prov, pending_rows(prov), {}};
  Handle file = write_file_atomically(path, content, nullptr, true);
  return std::unique_ptr<ResultsWriter>(new ResultsWriter(open_datasets(path, std::move(file), prov)));
}

std::unique_ptr<ResultsWriter> ResultsWriter::open(const std::string& path) {
  silence_hdf5();
  Ctx c{path};
  Handle fapl = access_plist(c, true);
  Handle file(c.ok(H5Fopen(path.c_str(), H5F_ACC_RDWR, fapl.get()), "cannot open file for writing"), H5Fclose);
  const Provenance p = read_provenance(c, file.get());
  return std::unique_ptr<ResultsWriter>(new ResultsWriter(open_datasets(path, std::move(file), p)));
}

void ResultsWriter::write_rows(const std::vector<ReplicateRecord>& records, const std::vector<float>& series) {
  if (records.empty()) return;
  const Ctx& c = impl_->c;
  std::vector<hsize_t> coords;
  for (const ReplicateRecord& r : records) {
    if (r.id >= impl_->replicates) c.fail("replicate id " + std::to_string(r.id) + " out of range");
    coords.push_back(r.id);
  }
  const hsize_t n = records.size();
  Handle mem = space_handle(c, H5Screate_simple(1, &n, nullptr), "memory space");
  Handle fs = space_handle(c, H5Dget_space(impl_->rows.get()), "file space");
  c.ok_status(H5Sselect_elements(fs.get(), H5S_SELECT_SET, n, coords.data()), "select rows");
  c.ok_status(H5Dwrite(impl_->rows.get(), impl_->record_t.get(), mem.get(), fs.get(), H5P_DEFAULT, records.data()),
              "write rows");
  const auto L = static_cast<hsize_t>(impl_->series_length);
  if (L > 0 && series.size() == n * L) {
    Handle ss = space_handle(c, H5Dget_space(impl_->series.get()), "series space");
    const hsize_t row_count[2] = {1, L};
    const hsize_t mem_dims[1] = {L};
    Handle ms = space_handle(c, H5Screate_simple(1, mem_dims, nullptr), "series memory space");
    for (hsize_t k = 0; k < n; ++k) {
      const hsize_t start[2] = {coords[k], 0};
      c.ok_status(H5Sselect_hyperslab(ss.get(), H5S_SELECT_SET, start, nullptr, row_count, nullptr), "select series");
      c.ok_status(H5Dwrite(impl_->series.get(), H5T_NATIVE_FLOAT, ms.get(), ss.get(), H5P_DEFAULT, &series[k * L]),
                  "write series");
    }
  }
  c.ok_status(H5Fflush(impl_->file.get(), H5F_SCOPE_GLOBAL), "flush");
}

void ResultsWriter::close() {
  const Ctx& c = impl_->c;
  impl_->rows.reset();
  impl_->series.reset();
  impl_->record_t.reset();
  if (impl_->file.close() < 0) c.fail("close");
}

// ---- Reading -------------------------------------------------------------------

ResultsContent read_results(const std::string& path, bool with_series) {
  silence_hdf5();
  Ctx c{path};
  if (FILE* f = std::fopen(path.c_str(), "rb")) {
    std::fclose(f);
  } else {
    throw ResultsFileError(path + ": cannot open: " + std::strerror(errno));
  }
  if (H5Fis_hdf5(path.c_str()) <= 0) throw ResultsFileError(path + ": not an HDF5 file (or a damaged one)");
  Handle file(c.ok(H5Fopen(path.c_str(), H5F_ACC_RDONLY, H5P_DEFAULT), "cannot open file"), H5Fclose);
  ResultsContent out;
  out.provenance = read_provenance(c, file.get());
  Handle rows(c.ok(H5Dopen2(file.get(), "replicates", H5P_DEFAULT), "open /replicates"), H5Dclose);
  Handle fs = space_handle(c, H5Dget_space(rows.get()), "space of /replicates");
  hsize_t n = 0;
  if (H5Sget_simple_extent_ndims(fs.get()) != 1) c.fail("/replicates is not one-dimensional");
  H5Sget_simple_extent_dims(fs.get(), &n, nullptr);
  out.records.resize(n);
  Handle rt = record_type(c);
  // HDF5 converts compound fields by name: files with extra or reordered
  // columns read the same.
  if (n > 0) c.ok_status(H5Dread(rows.get(), rt.get(), H5S_ALL, H5S_ALL, H5P_DEFAULT, out.records.data()), "read /replicates");
  const auto L = static_cast<hsize_t>(out.provenance.series_length);
  if (with_series && L > 0 && n > 0) {
    Handle s(c.ok(H5Dopen2(file.get(), "series/N_t", H5P_DEFAULT), "open /series/N_t"), H5Dclose);
    out.series.resize(n * L);
    c.ok_status(H5Dread(s.get(), H5T_NATIVE_FLOAT, H5S_ALL, H5S_ALL, H5P_DEFAULT, out.series.data()),
                "read /series/N_t");
  }
  return out;
}

void write_results_atomically(const std::string& path, const ResultsContent& content,
                              const EnsembleSummary& summary) {
  write_file_atomically(path, content, &summary, false);
}

}  // namespace ringsim
