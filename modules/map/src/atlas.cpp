#include "dslam/map/atlas.h"

#include <cstring>
#include <fstream>
#include <set>

#include "dslam/core/atomic_file.h"
#include "dslam/core/error.h"
#include "dslam/core/log.h"

IMPLEMENTS_MRPT_OBJECT(Atlas, MapManager, dslam)

namespace dslam {

Atlas::Atlas() { reset(); }

std::string Atlas::description() const {
  return "Atlas: several maps (a new one when tracking is lost), merged by place recognition; binary save/load";
}

std::vector<ParamSpec> Atlas::paramSpecs() const { return {}; }

void Atlas::configure(const Params& p, const PluginContext& ctx) { Plugin::configure(p, ctx); }

std::shared_ptr<Map> Atlas::currentMap() { return current_; }

std::shared_ptr<Map> Atlas::createMap() {
  auto m = std::make_shared<Map>(next_map_id_++);
  maps_.push_back(m);
  current_ = m;
  return m;
}

std::vector<std::shared_ptr<Map>> Atlas::maps() const { return maps_; }

void Atlas::reset() {
  for (auto& m : maps_) m->clear();
  maps_.clear();
  current_.reset();
  createMap();
}

void Atlas::eraseMap(const std::shared_ptr<Map>& m) {
  maps_.erase(std::remove(maps_.begin(), maps_.end(), m), maps_.end());
  if (current_ == m) current_ = maps_.empty() ? createMap() : maps_.back();
}

void Atlas::setCurrent(const std::shared_ptr<Map>& m) { current_ = m; }

std::shared_ptr<Map> Atlas::map(int64_t id) const {
  for (const auto& m : maps_)
    if (m->id == id) return m;
  return nullptr;
}

// ---------------------------------------------------------------------------
// Binary file
// ---------------------------------------------------------------------------

namespace {

constexpr char kMagic[8] = {'D', 'S', 'L', 'A', 'M', 'A', 'T', 'L'};
constexpr char kEnd[8] = {'D', 'S', 'L', 'A', 'M', 'E', 'N', 'D'};
constexpr uint32_t kEndian = 0x01020304u;

class Writer {
 public:
  explicit Writer(const std::string& path) : out_(path, std::ios::binary), f_(out_.stream()) {}
  template <class T>
  void put(const T& v) {
    static_assert(std::is_trivially_copyable_v<T>);
    f_.write(reinterpret_cast<const char*>(&v), sizeof(T));
  }
  void bytes(const void* p, size_t n) { f_.write(static_cast<const char*>(p), static_cast<std::streamsize>(n)); }
  /** The file appears under its name only now (temporary file + rename). */
  void finish() { out_.commit(); }

 private:
  AtomicOfstream out_;
  std::ofstream& f_;
};

class Reader {
 public:
  explicit Reader(const std::string& path) : f_(path, std::ios::binary), path_(path) {
    if (!f_) throw DataError("atlas file not found or unreadable: " + path);
    f_.seekg(0, std::ios::end);
    size_ = static_cast<uint64_t>(std::max<std::streamoff>(0, f_.tellg()));
    f_.seekg(0, std::ios::beg);
  }
  template <class T>
  T get() {
    T v{};
    bytes(&v, sizeof(T));
    return v;
  }
  void bytes(void* p, size_t n) {
    if (!tryBytes(p, n)) fail("truncated");
  }
  /** Reads n bytes; false if the file ends first. */
  bool tryBytes(void* p, size_t n) {
    f_.read(static_cast<char*>(p), static_cast<std::streamsize>(n));
    const auto got = static_cast<size_t>(f_.gcount());
    if (got != n) return false;
    pos_ += got;
    return true;
  }
  /** A count field, checked against a sanity limit and against the bytes
   *  left in the file (each item takes at least `item_bytes`), so that
   *  no count drives an allocation the file cannot fill. */
  uint64_t count(uint64_t limit, const char* what, uint64_t item_bytes) {
    const uint64_t n = get<uint64_t>();
    if (n > limit) fail(std::string("implausible ") + what + " count " + std::to_string(n));
    const uint64_t left = size_ > pos_ ? size_ - pos_ : 0;
    if (n > left / item_bytes)
      fail(std::string(what) + " count " + std::to_string(n) + " needs at least " + std::to_string(n * item_bytes) +
           " bytes, the file has " + std::to_string(left) + " left");
    return n;
  }
  [[noreturn]] void fail(const std::string& what) {
    throw DataError("atlas file " + path_ + " is corrupt (" + what + " at byte " + std::to_string(pos_) +
                    "); it was not written by this dslam version or was damaged");
  }

 private:
  std::ifstream f_;
  std::string path_;
  uint64_t pos_ = 0;   ///< bytes read so far
  uint64_t size_ = 0;  ///< file size
};

void putPose(Writer& w, const SE3& T) {
  const auto& q = T.quaternion();
  const auto& t = T.translation();
  for (double v : {q.w(), q.x(), q.y(), q.z(), t.x(), t.y(), t.z()}) w.put(v);
}

SE3 getPose(Reader& r) {
  double v[7];
  for (double& x : v) x = r.get<double>();
  for (double x : v)
    if (!std::isfinite(x)) r.fail("non-finite pose");
  Eigen::Quaterniond q(v[0], v[1], v[2], v[3]);
  if (q.norm() < 1e-6) r.fail("zero quaternion");
  return SE3(q.normalized(), Eigen::Vector3d(v[4], v[5], v[6]));
}

}  // namespace

void Atlas::save(const std::string& path) const {
  Writer w(path);
  w.bytes(kMagic, 8);
  w.put(kFileVersion);
  w.put(kEndian);
  w.put(static_cast<uint64_t>(maps_.size()));
  w.put(static_cast<int64_t>(current_ ? current_->id : -1));
  size_t n_kf = 0, n_pt = 0;
  for (const auto& m : maps_) {
    std::lock_guard<std::recursive_mutex> lk(m->update_mutex);
    w.put(m->id);
    w.put(static_cast<int64_t>(m->origin() ? m->origin()->id : -1));
    w.put(static_cast<uint64_t>(m->keyframes().size()));
    for (const auto& [id, kf] : m->keyframes()) {
      n_kf++;
      w.put(kf->id);
      w.put(static_cast<int32_t>(kf->frame_index));
      w.put(kf->timestamp);
      const auto& c = kf->cam;
      for (float v : {c.fx, c.fy, c.cx, c.cy, c.invfx, c.invfy, c.bf, c.close_depth, c.bounds.min_x, c.bounds.max_x,
                      c.bounds.min_y, c.bounds.max_y})
        w.put(v);
      w.put(static_cast<int32_t>(kf->scale->n_levels));
      w.put(kf->scale->scale_factor);
      putPose(w, kf->T_cw());
      w.put(static_cast<int64_t>(kf->parent ? kf->parent->id : -1));
      w.put(static_cast<uint64_t>(kf->loop_edges.size()));
      for (const auto& [lid, l] : kf->loop_edges) w.put(lid);
      w.put(static_cast<uint8_t>(kf->not_erase));
      const uint64_t n = kf->keys_un.size();
      w.put(n);
      for (size_t i = 0; i < n; i++) {
        const auto& k = kf->keys_un[i];
        for (float v : {k.pt.x, k.pt.y, k.size, k.angle, k.response}) w.put(v);
        w.put(static_cast<int32_t>(k.octave));
        w.put(kf->depth[i]);
        w.put(kf->u_right[i]);
        const KeypointMeta m = kf->meta.empty() ? KeypointMeta{} : kf->meta[i];
        w.put(static_cast<uint8_t>(m.label));
        w.put(static_cast<uint8_t>(m.reason));
        w.put(m.class_id);
        w.put(m.object_id);
      }
      w.bytes(kf->descriptors.data, n * 32);
    }
    w.put(static_cast<uint64_t>(m->points().size()));
    for (const auto& [id, p] : m->points()) {
      n_pt++;
      w.put(p->id);
      w.put(p->first_kf_id);
      for (double v : {p->pos.x(), p->pos.y(), p->pos.z()}) w.put(v);
      w.bytes(p->desc.data(), 32);
      w.put(static_cast<int64_t>(p->ref_kf ? p->ref_kf->id : -1));
      w.put(p->class_id);
      w.put(p->object_id);
      w.put(static_cast<uint8_t>(p->label));
      w.put(static_cast<uint8_t>(p->active));
      w.put(p->map_object);  // version 2
      w.put(static_cast<uint64_t>(p->observations().size()));
      for (const auto& [kid, o] : p->observations()) {
        w.put(kid);
        w.put(static_cast<int32_t>(o.second));
      }
    }
    // Version 2: the map's objects (semantic map, persistence beliefs).
    w.put(static_cast<uint64_t>(m->objects().size()));
    for (const auto& [oid, o] : m->objects()) {
      w.put(o->id);
      w.put(static_cast<int32_t>(o->class_id));
      w.put(o->belief);
      w.put(static_cast<uint8_t>(o->active));
      w.put(static_cast<uint8_t>(o->dormant));
      w.put(o->first_seen_kf);
      w.put(o->last_seen_kf);
      w.put(o->first_seen_t);
      w.put(o->last_seen_t);
      w.put(static_cast<int32_t>(o->sightings));
      for (const cv::Rect2f& b : {o->first_box, o->current_box})
        for (float v : {b.x, b.y, b.width, b.height}) w.put(v);
      w.put(static_cast<uint64_t>(o->points.size()));
      for (const auto& [pid, p] : o->points) w.put(pid);
    }
  }
  w.bytes(kEnd, 8);
  w.finish();
  DSLAM_LOG(Info, "atlas saved to " << path << ": " << maps_.size() << " map(s), " << n_kf << " keyframes, " << n_pt
                                    << " points");
}

namespace {

/** What the atlas file holds for the expected camera of the pipeline. */
struct Expected {
  const std::optional<CameraIntrinsics>& cam;
  const std::shared_ptr<const ScaleLevels>& scale;
};

/** A keyframe as read, with the links resolved once all keyframes exist. */
struct KeyFrameRecord {
  KeyFramePtr kf;
  int64_t parent = -1;
  std::vector<int64_t> loops;
};

CameraIntrinsics readIntrinsics(Reader& r) {
  CameraIntrinsics c;
  float v[12];
  for (float& x : v) x = r.get<float>();
  c.fx = v[0], c.fy = v[1], c.cx = v[2], c.cy = v[3], c.invfx = v[4], c.invfy = v[5], c.bf = v[6], c.close_depth = v[7];
  c.bounds = {v[8], v[9], v[10], v[11]};
  for (float x : v)
    if (!std::isfinite(x)) r.fail("non-finite keyframe intrinsics");
  // The image bounds size the feature grid: at least a pixel, at most 1e5.
  const float bw = c.bounds.max_x - c.bounds.min_x, bh = c.bounds.max_y - c.bounds.min_y;
  if (!(c.fx > 0) || !(c.fy > 0) || !(bw >= 1 && bw <= 1e5f) || !(bh >= 1 && bh <= 1e5f))
    r.fail("bad keyframe intrinsics");
  return c;
}

/** Keypoints, depths, labels and descriptors of one keyframe into `f`. */
void readKeypoints(Reader& r, int32_t n_levels, Frame& f) {
  const uint64_t n = r.count(1'000'000, "keypoint", 5 * 4 + 4 + 4 + 4 + 1 + 1 + 2 + 4 + 32);
  f.keypoints_un.resize(n);
  f.depth.resize(n);
  f.u_right.resize(n);
  f.meta.resize(n);
  for (uint64_t i = 0; i < n; i++) {
    float kv[5];
    for (float& x : kv) x = r.get<float>();
    for (float x : kv)
      if (!std::isfinite(x)) r.fail("non-finite keypoint");
    const int32_t oct = r.get<int32_t>();
    if (oct < 0 || oct >= n_levels) r.fail("keypoint octave out of range");
    f.keypoints_un[i] = cv::KeyPoint(kv[0], kv[1], kv[2], kv[3], kv[4], oct);
    f.depth[i] = r.get<float>();
    f.u_right[i] = r.get<float>();
    const uint8_t label = r.get<uint8_t>();
    if (label > 2) r.fail("keypoint label out of range");
    f.meta[i].label = static_cast<KpLabel>(label);
    f.meta[i].reason = static_cast<KpReason>(r.get<uint8_t>());
    f.meta[i].class_id = r.get<int16_t>();
    f.meta[i].object_id = r.get<int32_t>();
  }
  f.keypoints = f.keypoints_un;
  f.descriptors = cv::Mat(static_cast<int>(n), 32, CV_8U);
  if (n) r.bytes(f.descriptors.data, n * 32);
}

KeyFrameRecord readKeyFrame(Reader& r, const std::string& path, const Expected& exp, Map* m) {
  KeyFrameRecord rec;
  const int64_t id = r.get<int64_t>();
  Frame f;
  f.input.index = r.get<int32_t>();
  f.input.timestamp = r.get<double>();
  const CameraIntrinsics c = readIntrinsics(r);
  const int32_t n_levels = r.get<int32_t>();
  const float factor = r.get<float>();
  if (n_levels < 1 || n_levels > 32 || !(factor > 1.f)) r.fail("bad pyramid");
  if (exp.scale && (n_levels != exp.scale->n_levels || std::abs(factor - exp.scale->scale_factor) > 1e-6f))
    throw DataError(path + ": the atlas was built with " + std::to_string(n_levels) + " pyramid levels / factor " +
                    std::to_string(factor) + "; the pipeline uses " + std::to_string(exp.scale->n_levels) + " / " +
                    std::to_string(exp.scale->scale_factor));
  if (exp.cam && (std::abs(exp.cam->fx - c.fx) > 1e-3f || std::abs(exp.cam->cx - c.cx) > 1e-3f))
    throw DataError(path + ": the atlas was built with another camera (fx " + std::to_string(c.fx) + ", pipeline fx " +
                    std::to_string(exp.cam->fx) + ")");
  const SE3 T = getPose(r);
  rec.parent = r.get<int64_t>();
  const uint64_t n_loops = r.count(100000, "loop edge", 8);
  for (uint64_t l = 0; l < n_loops; l++) rec.loops.push_back(r.get<int64_t>());
  const bool not_erase = r.get<uint8_t>() != 0;
  readKeypoints(r, n_levels, f);
  auto scale = (exp.scale && exp.scale->n_levels == n_levels)
                   ? exp.scale
                   : std::make_shared<const ScaleLevels>(ScaleLevels::make(n_levels, factor));
  rec.kf = std::make_shared<KeyFrame>(id, f, T, c, scale, m);
  rec.kf->not_erase = not_erase;
  return rec;
}

MapPointPtr readPoint(Reader& r, Map* m, const std::map<int64_t, KeyFramePtr>& kfs, uint32_t version) {
  const int64_t id = r.get<int64_t>();
  const int64_t first_kf = r.get<int64_t>();
  Eigen::Vector3d X;
  for (int a = 0; a < 3; a++) X[a] = r.get<double>();
  if (!X.allFinite()) r.fail("non-finite point");
  Descriptor d;
  r.bytes(d.data(), 32);
  const int64_t ref = r.get<int64_t>();
  auto it_first = kfs.find(first_kf);
  auto mp = std::make_shared<MapPoint>(id, X, it_first != kfs.end() ? it_first->second.get() : nullptr, m);
  mp->desc = d;
  mp->class_id = r.get<int16_t>();
  mp->object_id = r.get<int32_t>();
  const uint8_t label = r.get<uint8_t>();
  if (label > 2) r.fail("point label out of range");
  mp->label = static_cast<KpLabel>(label);
  mp->active = r.get<uint8_t>() != 0;
  if (version >= 2) mp->map_object = r.get<int64_t>();
  const uint64_t n_obs = r.count(1'000'000, "observation", 8 + 4);
  for (uint64_t o = 0; o < n_obs; o++) {
    const int64_t kid = r.get<int64_t>();
    const int32_t idx = r.get<int32_t>();
    auto it = kfs.find(kid);
    if (it == kfs.end()) r.fail("observation of an unknown keyframe");
    if (idx < 0 || static_cast<size_t>(idx) >= it->second->size()) r.fail("observation index out of range");
    mp->addObservation(it->second.get(), idx);
    it->second->points[idx] = mp;
  }
  if (auto it = kfs.find(ref); it != kfs.end()) mp->ref_kf = it->second.get();
  mp->updateNormalAndDepth();
  return mp;
}

/** One map: keyframes (origin first), points, then covisibility, spanning
 *  tree and loop edges. Raises max_kf / max_pt to the largest ids read. */
/** Version 2: the objects of map `m` (their points must be read). */
void readObjects(Reader& r, Map& m, int64_t& max_obj) {
  const uint64_t n = r.count(10'000'000, "object", 8 + 4 + 8 + 1 + 1 + 8 * 4 + 4 + 8 * 4 + 8);
  for (uint64_t k = 0; k < n; k++) {
    auto o = std::make_shared<MapObject>();
    o->id = r.get<int64_t>();
    if (o->id < 0 || m.objects().count(o->id)) r.fail("bad or duplicate object id");
    o->class_id = r.get<int32_t>();
    o->belief = r.get<double>();
    if (!(o->belief >= 0 && o->belief <= 1)) r.fail("object belief outside [0, 1]");
    o->active = r.get<uint8_t>() != 0;
    o->dormant = r.get<uint8_t>() != 0;
    o->first_seen_kf = r.get<int64_t>();
    o->last_seen_kf = r.get<int64_t>();
    o->first_seen_t = r.get<double>();
    o->last_seen_t = r.get<double>();
    o->sightings = r.get<int32_t>();
    for (cv::Rect2f* b : {&o->first_box, &o->current_box}) {
      float v[4];
      for (float& x : v) x = r.get<float>();
      *b = cv::Rect2f(v[0], v[1], v[2], v[3]);
    }
    const uint64_t np = r.count(100'000'000, "object point", 8);
    for (uint64_t i = 0; i < np; i++) {
      const int64_t pid = r.get<int64_t>();
      auto it = m.points().find(pid);
      if (it == m.points().end()) r.fail("object point of an unknown map point");
      o->points[pid] = it->second;
    }
    o->refresh();
    max_obj = std::max(max_obj, o->id);
    m.objects()[o->id] = o;
  }
}

std::shared_ptr<Map> readMap(Reader& r, const std::string& path, const Expected& exp, int64_t& max_kf,
                             int64_t& max_pt, uint32_t version, int64_t& max_obj) {
  auto m = std::make_shared<Map>(r.get<int64_t>());
  const int64_t origin_id = r.get<int64_t>();
  const uint64_t n_kf = r.count(10'000'000, "keyframe", 8 + 4 + 8 + 12 * 4 + 4 + 4 + 7 * 8 + 8 + 8 + 1 + 8);
  std::map<int64_t, KeyFramePtr> kfs;
  std::vector<KeyFrameRecord> in_order;
  for (uint64_t k = 0; k < n_kf; k++) {
    KeyFrameRecord rec = readKeyFrame(r, path, exp, m.get());
    const int64_t id = rec.kf->id;
    if (kfs.count(id)) r.fail("duplicate keyframe id");
    kfs[id] = rec.kf;
    in_order.push_back(std::move(rec));
    max_kf = std::max(max_kf, id);
  }
  // The origin first: Map::addKeyFrame takes the first keyframe as origin.
  if (origin_id >= 0) {
    if (!kfs.count(origin_id)) r.fail("origin keyframe missing");
    m->addKeyFrame(kfs[origin_id]);
  }
  for (auto& rec : in_order)
    if (rec.kf->id != origin_id) m->addKeyFrame(rec.kf);
  const uint64_t n_pt = r.count(100'000'000, "point", 8 + 8 + 3 * 8 + 32 + 8 + 2 + 4 + 1 + 1 + 8);
  for (uint64_t k = 0; k < n_pt; k++) {
    MapPointPtr mp = readPoint(r, m.get(), kfs, version);
    max_pt = std::max(max_pt, mp->id);
    m->addPoint(mp);
  }
  if (version >= 2) readObjects(r, *m, max_obj);
  for (auto& rec : in_order) rec.kf->updateConnections();
  for (auto& rec : in_order) {
    auto pit = kfs.find(rec.parent);
    rec.kf->changeParent(pit != kfs.end() ? pit->second.get() : nullptr);
    for (int64_t l : rec.loops)
      if (auto lit = kfs.find(l); lit != kfs.end()) rec.kf->loop_edges[l] = lit->second.get();
  }
  return m;
}

}  // namespace

void Atlas::load(const std::string& path) {
  Reader r(path);
  char magic[8];
  if (!r.tryBytes(magic, 8) || std::memcmp(magic, kMagic, 8) != 0)
    throw DataError(path + " is not a dslam atlas file (expected the 'DSLAMATL' header written by dslam run with outputs.atlas)");
  const uint32_t version = r.get<uint32_t>();
  if (version < 1 || version > kFileVersion)
    throw DataError(path + ": atlas file version " + std::to_string(version) +
                    " is not supported (this dslam reads versions 1 to " + std::to_string(kFileVersion) +
                    "); save it again with this version");
  if (r.get<uint32_t>() != kEndian) throw DataError(path + ": atlas file written on a machine with another byte order");
  const uint64_t n_maps = r.count(1 << 16, "map", 8 + 8 + 8 + 8);
  const int64_t current_id = r.get<int64_t>();
  const Expected exp{exp_cam_, exp_scale_};
  std::vector<std::shared_ptr<Map>> maps;
  int64_t max_kf = -1, max_pt = -1, max_map = -1, max_obj = -1;
  for (uint64_t mi = 0; mi < n_maps; mi++) {
    maps.push_back(readMap(r, path, exp, max_kf, max_pt, version, max_obj));
    max_map = std::max(max_map, maps.back()->id);
  }
  char end[8];
  r.bytes(end, 8);
  if (std::memcmp(end, kEnd, 8) != 0) r.fail("missing end marker");
  // Commit only after the whole file was read.
  for (auto& m : maps_) m->clear();
  maps_ = maps;
  current_.reset();
  for (auto& m : maps_)
    if (m->id == current_id) current_ = m;
  if (!current_) current_ = maps_.empty() ? nullptr : maps_.back();
  next_map_id_ = max_map + 1;
  if (!current_) createMap();
  Map::reserveIds(max_kf, max_pt);
  Map::objectIdCounter() = std::max(Map::objectIdCounter(), max_obj + 1);
  size_t nk = 0, np = 0;
  for (auto& m : maps_) {
    nk += m->numKeyFrames();
    np += m->numPoints();
  }
  DSLAM_LOG(Info, "atlas loaded from " << path << ": " << maps_.size() << " map(s), " << nk << " keyframes, " << np
                                       << " points");
}

}  // namespace dslam
