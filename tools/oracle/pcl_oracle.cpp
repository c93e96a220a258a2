// PCL 1.13 oracle for softsense's tests and benchmarks.
//
// Usage: pcl_oracle JOB.json
//   JOB = {"stage": "...", "input": "/abs/in", "output_dir": "/abs/dir",
//          "params": {...}, "repeat": 1}
// Writes output_dir/result.json (always, also on failure: ok=false, error="...") and, for
// stages that produce a cloud, output_dir/cloud.pcd (binary PCD written by PCL).
// Stages and their parameters are documented in tools/oracle/README.md.
// Exit status: 0 when result.json says ok, 1 otherwise, 2 when the job file is unusable.

#include <pcl/PCLPointCloud2.h>
#include <pcl/common/io.h>
#include <pcl/features/normal_3d.h>
#include <pcl/filters/crop_box.h>
#include <pcl/filters/passthrough.h>
#include <pcl/filters/radius_outlier_removal.h>
#include <pcl/filters/statistical_outlier_removal.h>
#include <pcl/filters/voxel_grid.h>
#include <pcl/io/image_grabber.h>
#include <pcl/io/pcd_io.h>
#include <pcl/point_types.h>
#include <pcl/search/kdtree.h>
#include <pcl/segmentation/extract_clusters.h>
#include <pcl/segmentation/region_growing_rgb.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <fstream>
#include <functional>
#include <map>
#include <memory>
#include <sstream>
#include <stdexcept>
#include <string>
#include <vector>

namespace {

// ---------------------------------------------------------------------------------------
// A minimal JSON value and parser: enough for job files (objects, arrays, strings without
// exotic escapes, numbers, booleans, null).
struct Json {
  enum Kind { Null, Bool, Number, String, Array, Object } kind = Null;
  bool b = false;
  double num = 0.0;
  std::string str;
  std::vector<Json> arr;
  std::map<std::string, Json> obj;

  const Json* get(const std::string& key) const {
    if (kind != Object) return nullptr;
    auto it = obj.find(key);
    return it == obj.end() ? nullptr : &it->second;
  }
};

class Parser {
 public:
  explicit Parser(const std::string& text) : s_(text) {}
  Json parse() {
    Json v = value();
    ws();
    if (i_ != s_.size()) fail("trailing characters");
    return v;
  }

 private:
  const std::string& s_;
  std::size_t i_ = 0;

  [[noreturn]] void fail(const std::string& what) {
    throw std::runtime_error("job JSON: " + what + " at byte " + std::to_string(i_));
  }
  void ws() {
    while (i_ < s_.size() && std::isspace(static_cast<unsigned char>(s_[i_]))) ++i_;
  }
  bool lit(const char* word) {
    std::size_t n = std::char_traits<char>::length(word);
    if (s_.compare(i_, n, word) == 0) {
      i_ += n;
      return true;
    }
    return false;
  }
  Json value() {
    ws();
    if (i_ >= s_.size()) fail("unexpected end");
    Json v;
    char c = s_[i_];
    if (c == '{') {
      v.kind = Json::Object;
      ++i_;
      ws();
      if (i_ < s_.size() && s_[i_] == '}') {
        ++i_;
        return v;
      }
      for (;;) {
        ws();
        if (i_ >= s_.size() || s_[i_] != '"') fail("expected key");
        std::string key = string();
        ws();
        if (i_ >= s_.size() || s_[i_] != ':') fail("expected ':'");
        ++i_;
        v.obj[key] = value();
        ws();
        if (i_ < s_.size() && s_[i_] == ',') {
          ++i_;
          continue;
        }
        if (i_ < s_.size() && s_[i_] == '}') {
          ++i_;
          return v;
        }
        fail("expected ',' or '}'");
      }
    }
    if (c == '[') {
      v.kind = Json::Array;
      ++i_;
      ws();
      if (i_ < s_.size() && s_[i_] == ']') {
        ++i_;
        return v;
      }
      for (;;) {
        v.arr.push_back(value());
        ws();
        if (i_ < s_.size() && s_[i_] == ',') {
          ++i_;
          continue;
        }
        if (i_ < s_.size() && s_[i_] == ']') {
          ++i_;
          return v;
        }
        fail("expected ',' or ']'");
      }
    }
    if (c == '"') {
      v.kind = Json::String;
      v.str = string();
      return v;
    }
    if (lit("true")) {
      v.kind = Json::Bool;
      v.b = true;
      return v;
    }
    if (lit("false")) {
      v.kind = Json::Bool;
      return v;
    }
    if (lit("null")) return v;
    const char* start = s_.c_str() + i_;
    char* end = nullptr;
    v.num = std::strtod(start, &end);
    if (end == start) fail("bad value");
    i_ += static_cast<std::size_t>(end - start);
    v.kind = Json::Number;
    return v;
  }
  std::string string() {
    ++i_;  // opening quote
    std::string out;
    while (i_ < s_.size() && s_[i_] != '"') {
      char c = s_[i_++];
      if (c == '\\') {
        if (i_ >= s_.size()) fail("bad escape");
        char e = s_[i_++];
        switch (e) {
          case 'n': out += '\n'; break;
          case 't': out += '\t'; break;
          case 'r': out += '\r'; break;
          case 'b': out += '\b'; break;
          case 'f': out += '\f'; break;
          case 'u': fail("\\u escapes are not supported");
          default: out += e;
        }
      } else {
        out += c;
      }
    }
    if (i_ >= s_.size()) fail("unterminated string");
    ++i_;
    return out;
  }
};

std::string json_escape(const std::string& s) {
  std::string out = "\"";
  for (char c : s) {
    if (c == '"' || c == '\\') {
      out += '\\';
      out += c;
    } else if (c == '\n') {
      out += "\\n";
    } else if (static_cast<unsigned char>(c) < 0x20) {
      char buf[8];
      std::snprintf(buf, sizeof buf, "\\u%04x", c);
      out += buf;
    } else {
      out += c;
    }
  }
  return out + "\"";
}

std::string json_number(double v) {
  if (!std::isfinite(v)) return "null";
  char buf[64];
  std::snprintf(buf, sizeof buf, "%.17g", v);
  return buf;
}

// ---------------------------------------------------------------------------------------
// Parameters.
double num_param(const Json& params, const std::string& key) {
  const Json* v = params.get(key);
  if (!v || v->kind != Json::Number) throw std::runtime_error("param `" + key + "` (number) is required");
  return v->num;
}
double num_param_or(const Json& params, const std::string& key, double dflt) {
  const Json* v = params.get(key);
  if (!v || v->kind == Json::Null) return dflt;
  if (v->kind != Json::Number) throw std::runtime_error("param `" + key + "` must be a number");
  return v->num;
}
bool bool_param_or(const Json& params, const std::string& key, bool dflt) {
  const Json* v = params.get(key);
  if (!v || v->kind == Json::Null) return dflt;
  if (v->kind != Json::Bool) throw std::runtime_error("param `" + key + "` must be true or false");
  return v->b;
}
std::string str_param(const Json& params, const std::string& key) {
  const Json* v = params.get(key);
  if (!v || v->kind != Json::String) throw std::runtime_error("param `" + key + "` (string) is required");
  return v->str;
}
std::vector<double> vec3_param(const Json& params, const std::string& key) {
  const Json* v = params.get(key);
  if (!v || v->kind != Json::Array || v->arr.size() != 3)
    throw std::runtime_error("param `" + key + "` must be an array of 3 numbers");
  std::vector<double> out;
  for (const Json& e : v->arr) {
    if (e.kind != Json::Number) throw std::runtime_error("param `" + key + "` must hold numbers");
    out.push_back(e.num);
  }
  return out;
}

// ---------------------------------------------------------------------------------------
// The result being built.
struct Result {
  std::string stage;
  long long points = -1, width = -1, height = -1;
  std::vector<std::string> fields;
  bool has_indices = false;
  std::vector<int> indices;
  std::vector<double> timings_ms;
  std::vector<std::pair<std::string, std::string>> extra;  // key -> JSON text

  std::string to_json(bool ok, const std::string& error) const {
    std::ostringstream o;
    o << "{\"library\": \"pcl\", \"version\": " << json_escape(PCL_VERSION_PRETTY)
      << ", \"stage\": " << json_escape(stage) << ", \"ok\": " << (ok ? "true" : "false")
      << ", \"error\": " << (ok ? "null" : json_escape(error));
    if (points >= 0) o << ", \"points\": " << points;
    if (width >= 0) o << ", \"width\": " << width;
    if (height >= 0) o << ", \"height\": " << height;
    if (!fields.empty() || points >= 0) {
      o << ", \"fields\": [";
      for (std::size_t i = 0; i < fields.size(); ++i) o << (i ? ", " : "") << json_escape(fields[i]);
      o << "]";
    }
    if (has_indices) {
      o << ", \"indices\": [";
      for (std::size_t i = 0; i < indices.size(); ++i) o << (i ? "," : "") << indices[i];
      o << "]";
    }
    o << ", \"timings_ms\": [";
    for (std::size_t i = 0; i < timings_ms.size(); ++i) o << (i ? ", " : "") << json_number(timings_ms[i]);
    o << "]";
    for (const auto& kv : extra) o << ", " << json_escape(kv.first) << ": " << kv.second;
    o << "}\n";
    return o.str();
  }
};

// Runs `f` `repeat` times and records each wall time in milliseconds.
void timed(int repeat, Result& r, const std::function<void()>& f) {
  for (int i = 0; i < repeat; ++i) {
    auto t0 = std::chrono::steady_clock::now();
    f();
    auto t1 = std::chrono::steady_clock::now();
    r.timings_ms.push_back(std::chrono::duration<double, std::milli>(t1 - t0).count());
  }
}

std::vector<std::string> blob_fields(const pcl::PCLPointCloud2& blob) {
  std::vector<std::string> out;
  for (const auto& f : blob.fields)
    if (f.name != "_") out.push_back(f.name);
  return out;
}

bool has_field(const pcl::PCLPointCloud2& blob, const std::string& name) {
  for (const auto& f : blob.fields)
    if (f.name == name) return true;
  return false;
}

void load_blob(const std::string& path, pcl::PCLPointCloud2& blob, Eigen::Vector4f& origin,
               Eigen::Quaternionf& orientation) {
  pcl::PCDReader reader;
  int version = 0;
  if (reader.read(path, blob, origin, orientation, version) < 0)
    throw std::runtime_error("pcl::PCDReader could not read " + path);
}

template <typename PointT>
void save_cloud(const std::string& dir, const pcl::PointCloud<PointT>& cloud, Result& r) {
  if (pcl::io::savePCDFileBinary(dir + "/cloud.pcd", cloud) < 0)
    throw std::runtime_error("could not write " + dir + "/cloud.pcd");
  pcl::PCLPointCloud2 blob;
  pcl::toPCLPointCloud2(cloud, blob);
  r.points = static_cast<long long>(cloud.size());
  r.width = cloud.width;
  r.height = cloud.height;
  r.fields = blob_fields(blob);
}

// Flattens an organized cloud to height 1 so that PCL picks its KdTree rather than
// OrganizedNeighbor (oracle-semantics trap 9), unless params.organized is true.
template <typename PointT>
void maybe_flatten(pcl::PointCloud<PointT>& cloud, const Json& params) {
  if (!bool_param_or(params, "organized", false)) {
    cloud.width = static_cast<std::uint32_t>(cloud.size());
    cloud.height = 1;
  }
}

// What a selecting stage's timing covers: "indices" (default) or "cloud".
std::string timing_of(const Json& params) {
  const Json* t = params.get("time");
  if (!t) return "indices";
  if (t->kind != Json::String || (t->str != "indices" && t->str != "cloud"))
    throw std::runtime_error("`time` must be \"indices\" or \"cloud\"");
  return t->str;
}

// ---------------------------------------------------------------------------------------
// Stages on typed clouds (PointXYZRGBA when the input has colour, else PointXYZ).

template <typename PointT>
void stage_filters(const std::string& stage, const pcl::PCLPointCloud2& blob,
                   const Eigen::Vector4f& origin, const Eigen::Quaternionf& orientation,
                   const Json& params, int repeat, const std::string& out_dir, Result& r) {
  using Cloud = pcl::PointCloud<PointT>;
  typename Cloud::Ptr cloud(new Cloud);
  pcl::fromPCLPointCloud2(blob, *cloud);
  cloud->sensor_origin_ = origin;
  cloud->sensor_orientation_ = orientation;
  Cloud out;
  pcl::Indices kept;

  if (stage == "passthrough") {
    pcl::PassThrough<PointT> pt(true);
    pt.setInputCloud(cloud);
    pt.setFilterFieldName(str_param(params, "field"));
    pt.setFilterLimits(static_cast<float>(num_param(params, "min")),
                       static_cast<float>(num_param(params, "max")));
    pt.setNegative(bool_param_or(params, "negative", false));
    pt.setKeepOrganized(bool_param_or(params, "keep_organized", false));
    // "time": "cloud" times filter(out), the output cloud with every field (the caller's
    // `out` reused across repetitions); the default times filter(kept), indices only.
    if (timing_of(params) == "cloud") timed(repeat, r, [&] { pt.filter(out); });
    else timed(repeat, r, [&] { pt.filter(kept); });
    pt.filter(kept);
    pt.filter(out);
  } else if (stage == "crop_box") {
    std::vector<double> mn = vec3_param(params, "min"), mx = vec3_param(params, "max");
    pcl::CropBox<PointT> cb(true);
    cb.setInputCloud(cloud);
    cb.setMin(Eigen::Vector4f(mn[0], mn[1], mn[2], 1.0f));
    cb.setMax(Eigen::Vector4f(mx[0], mx[1], mx[2], 1.0f));
    cb.setNegative(bool_param_or(params, "invert", false));
    if (timing_of(params) == "cloud") timed(repeat, r, [&] { cb.filter(out); });
    else timed(repeat, r, [&] { cb.filter(kept); });
    cb.filter(kept);
    pcl::copyPointCloud(*cloud, kept, out);
  } else if (stage == "voxel") {
    float leaf = static_cast<float>(num_param(params, "leaf"));
    pcl::VoxelGrid<PointT> vg;
    vg.setInputCloud(cloud);
    vg.setLeafSize(leaf, leaf, leaf);
    vg.setDownsampleAllData(bool_param_or(params, "downsample_all_data", true));
    vg.setMinimumPointsNumberPerVoxel(static_cast<unsigned>(num_param_or(params, "min_points_per_voxel", 0)));
    timed(repeat, r, [&] { vg.filter(out); });
  } else if (stage == "radius_outlier") {
    // PCL 1.13 asserts (Debian builds keep asserts) on a NaN query point in the
    // non-dense radius path, so non-finite points are dropped first (they are never kept)
    // and the kept indices are mapped back to the input. `dense` picks PCL's path:
    // false = radius search (strict d < r), true = kNN path (d <= r).
    std::vector<int> finite_to_input;
    typename Cloud::Ptr finite(new Cloud);
    for (std::size_t i = 0; i < cloud->size(); ++i) {
      if (pcl::isFinite((*cloud)[i])) {
        finite->push_back((*cloud)[i]);
        finite_to_input.push_back(static_cast<int>(i));
      }
    }
    finite->width = static_cast<std::uint32_t>(finite->size());
    finite->height = 1;
    finite->is_dense = bool_param_or(params, "dense", false);
    pcl::RadiusOutlierRemoval<PointT> ror(true);
    ror.setInputCloud(finite);
    ror.setRadiusSearch(num_param(params, "radius"));
    ror.setMinNeighborsInRadius(static_cast<int>(num_param(params, "min_neighbors")));
    ror.setKeepOrganized(false);
    ror.setNegative(bool_param_or(params, "negative", false));
    timed(repeat, r, [&] { ror.filter(kept); });
    for (auto& k : kept) k = finite_to_input[static_cast<std::size_t>(k)];
    pcl::copyPointCloud(*cloud, kept, out);
  } else if (stage == "statistical_outlier") {
    maybe_flatten(*cloud, params);
    pcl::StatisticalOutlierRemoval<PointT> sor(true);
    sor.setInputCloud(cloud);
    sor.setMeanK(static_cast<int>(num_param(params, "mean_k")));
    sor.setStddevMulThresh(num_param(params, "stddev_mul"));
    sor.setKeepOrganized(false);
    sor.setNegative(bool_param_or(params, "negative", false));
    timed(repeat, r, [&] { sor.filter(kept); });
    pcl::copyPointCloud(*cloud, kept, out);
  } else if (stage == "normals") {
    maybe_flatten(*cloud, params);
    pcl::NormalEstimation<PointT, pcl::Normal> ne;
    ne.setInputCloud(cloud);
    typename pcl::search::KdTree<PointT>::Ptr tree(new pcl::search::KdTree<PointT>(false));
    ne.setSearchMethod(tree);
    const Json* k = params.get("k");
    const Json* radius = params.get("radius");
    bool use_k = k && k->kind == Json::Number;
    bool use_r = radius && radius->kind == Json::Number;
    if (use_k == use_r) throw std::runtime_error("normals: give exactly one of `k` and `radius`");
    if (use_k) ne.setKSearch(static_cast<int>(k->num));
    else ne.setRadiusSearch(radius->num);
    if (params.get("viewpoint")) {
      std::vector<double> vp = vec3_param(params, "viewpoint");
      ne.setViewPoint(vp[0], vp[1], vp[2]);
    }
    pcl::PointCloud<pcl::Normal> normals;
    timed(repeat, r, [&] { ne.compute(normals); });
    pcl::PointCloud<pcl::PointXYZ> xyz;
    pcl::copyPointCloud(*cloud, xyz);
    pcl::PointCloud<pcl::PointNormal> with_normals;
    pcl::concatenateFields(xyz, normals, with_normals);
    with_normals.sensor_origin_ = cloud->sensor_origin_;
    with_normals.sensor_orientation_ = cloud->sensor_orientation_;
    save_cloud(out_dir, with_normals, r);
    return;
  } else {
    throw std::runtime_error("unknown stage `" + stage + "`");
  }
  if (stage != "voxel") {
    r.has_indices = true;
    r.indices.assign(kept.begin(), kept.end());
    std::sort(r.indices.begin(), r.indices.end());
  }
  save_cloud(out_dir, out, r);
}

void stage_load(const std::string& input, int repeat, const std::string& out_dir, Result& r) {
  pcl::PCLPointCloud2 blob;
  Eigen::Vector4f origin;
  Eigen::Quaternionf orientation;
  timed(repeat, r, [&] {
    // pcl::io::loadPCDFile, with the viewpoint kept so the written file carries it too.
    if (pcl::io::loadPCDFile(input, blob, origin, orientation) < 0)
      throw std::runtime_error("pcl::io::loadPCDFile failed on " + input);
  });
  pcl::PCDWriter writer;
  if (writer.writeBinary(out_dir + "/cloud.pcd", blob, origin, orientation) < 0)
    throw std::runtime_error("could not write " + out_dir + "/cloud.pcd");
  r.points = static_cast<long long>(blob.width) * blob.height;
  r.width = blob.width;
  r.height = blob.height;
  r.fields = blob_fields(blob);
  std::ostringstream extra;
  extra << "{\"is_dense\": " << (blob.is_dense ? "true" : "false") << ", \"origin\": ["
        << json_number(origin[0]) << ", " << json_number(origin[1]) << ", " << json_number(origin[2])
        << "], \"orientation_wxyz\": [" << json_number(orientation.w()) << ", "
        << json_number(orientation.x()) << ", " << json_number(orientation.y()) << ", "
        << json_number(orientation.z()) << "]}";
  r.extra.emplace_back("header", extra.str());
}

// RGB-D: PCL's own ImageGrabber (VTK image readers + its back-projection), one frame.
void stage_rgbd(const std::string& depth, const Json& params, int repeat, const std::string& out_dir,
                Result& r) {
  std::string color = str_param(params, "color");
  double fx = num_param(params, "fx"), fy = num_param(params, "fy");
  double cx = num_param(params, "cx"), cy = num_param(params, "cy");
  float units = static_cast<float>(num_param_or(params, "depth_units", 0.001));
  pcl::PointCloud<pcl::PointXYZRGBA>::ConstPtr cloud;
  timed(repeat, r, [&] {
    pcl::ImageGrabber<pcl::PointXYZRGBA> grabber(std::vector<std::string>{depth}, 0.0f, false);
    grabber.setRGBImageFiles(std::vector<std::string>{color});
    grabber.setCameraIntrinsics(fx, fy, cx, cy);
    grabber.setDepthImageUnits(units);
    cloud = grabber[0];
  });
  if (!cloud || cloud->empty())
    throw std::runtime_error("pcl::ImageGrabber could not read " + depth + " / " + color);
  save_cloud(out_dir, *cloud, r);
}

// ---------------------------------------------------------------------------------------
// SEGMENTATION STAGES (owned by the `segment` work: region_growing_rgb, euclidean).
// Both drop non-finite points first (RegionGrowingRGB has no NaN guard, oracle-semantics
// trap 6) and flatten to height 1 (trap 9), then report `clusters` as lists of INPUT
// indices in PCL's own cluster order, points within a cluster in PCL's order.

template <typename PointT>
typename pcl::PointCloud<PointT>::Ptr finite_flat(const pcl::PCLPointCloud2& blob,
                                                   std::vector<int>& to_input) {
  pcl::PointCloud<PointT> all;
  pcl::fromPCLPointCloud2(blob, all);
  typename pcl::PointCloud<PointT>::Ptr finite(new pcl::PointCloud<PointT>);
  for (std::size_t i = 0; i < all.size(); ++i) {
    if (pcl::isFinite(all[i])) {
      finite->push_back(all[i]);
      to_input.push_back(static_cast<int>(i));
    }
  }
  finite->width = static_cast<std::uint32_t>(finite->size());
  finite->height = 1;
  finite->is_dense = true;
  return finite;
}

void put_clusters(const std::vector<pcl::PointIndices>& clusters, const std::vector<int>& to_input,
                  long long input_points, Result& r) {
  std::ostringstream o;
  o << "[";
  for (std::size_t c = 0; c < clusters.size(); ++c) {
    o << (c ? ", " : "") << "[";
    const auto& idx = clusters[c].indices;
    for (std::size_t i = 0; i < idx.size(); ++i) o << (i ? "," : "") << to_input[static_cast<std::size_t>(idx[i])];
    o << "]";
  }
  o << "]";
  r.extra.emplace_back("clusters", o.str());
  r.points = input_points;
}

void stage_segment(const std::string& stage, const pcl::PCLPointCloud2& blob, const Json& params,
                   int repeat, Result& r) {
  std::vector<int> to_input;
  std::vector<pcl::PointIndices> clusters;
  long long n = static_cast<long long>(blob.width) * blob.height;
  if (stage == "region_growing_rgb") {
    auto cloud = finite_flat<pcl::PointXYZRGB>(blob, to_input);
    auto tree = std::make_shared<pcl::search::KdTree<pcl::PointXYZRGB>>();
    pcl::RegionGrowingRGB<pcl::PointXYZRGB> rg;
    rg.setInputCloud(cloud);
    rg.setSearchMethod(tree);
    rg.setDistanceThreshold(static_cast<float>(num_param_or(params, "distance", std::sqrt(0.05))));
    rg.setPointColorThreshold(static_cast<float>(num_param_or(params, "point_color", 35)));
    rg.setRegionColorThreshold(static_cast<float>(num_param_or(params, "region_color", std::sqrt(10.0))));
    rg.setMinClusterSize(static_cast<pcl::uindex_t>(num_param_or(params, "min_cluster", 10)));
    double max_cluster = num_param_or(params, "max_cluster", -1);
    if (max_cluster >= 0) rg.setMaxClusterSize(static_cast<pcl::uindex_t>(max_cluster));
    rg.setNumberOfNeighbours(static_cast<unsigned>(num_param_or(params, "neighbours", 30)));
    rg.setNumberOfRegionNeighbours(static_cast<unsigned>(num_param_or(params, "region_neighbours", 100)));
    timed(repeat, r, [&] {
      clusters.clear();
      rg.extract(clusters);
    });
  } else if (stage == "euclidean") {
    auto cloud = finite_flat<pcl::PointXYZ>(blob, to_input);
    pcl::EuclideanClusterExtraction<pcl::PointXYZ> ece;  // default tree: KdTree(false)
    ece.setInputCloud(cloud);
    ece.setClusterTolerance(num_param(params, "tolerance"));
    ece.setMinClusterSize(static_cast<pcl::uindex_t>(num_param_or(params, "min", 1)));
    double mx = num_param_or(params, "max", -1);
    if (mx >= 0) ece.setMaxClusterSize(static_cast<pcl::uindex_t>(mx));
    timed(repeat, r, [&] {
      clusters.clear();  // extract() appends (oracle-semantics section 6)
      ece.extract(clusters);
    });
  } else {
    throw std::runtime_error("unknown stage `" + stage + "`");
  }
  put_clusters(clusters, to_input, n, r);
}
// END OF SEGMENTATION STAGES
// ---------------------------------------------------------------------------------------

std::string read_file(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  if (!in) throw std::runtime_error("cannot open job file " + path);
  std::ostringstream ss;
  ss << in.rdbuf();
  return ss.str();
}

}  // namespace

int main(int argc, char** argv) {
  if (argc != 2) {
    std::fprintf(stderr, "usage: %s JOB.json\n", argv[0]);
    return 2;
  }
  Json job;
  std::string out_dir, stage, input;
  int repeat = 1;
  try {
    job = Parser(read_file(argv[1])).parse();
    const Json* od = job.get("output_dir");
    const Json* st = job.get("stage");
    const Json* in = job.get("input");
    if (!od || od->kind != Json::String || !st || st->kind != Json::String || !in || in->kind != Json::String)
      throw std::runtime_error("job needs string keys stage, input, output_dir");
    out_dir = od->str;
    stage = st->str;
    input = in->str;
    const Json* rp = job.get("repeat");
    if (rp && rp->kind == Json::Number) repeat = std::max(1, static_cast<int>(rp->num));
  } catch (const std::exception& e) {
    std::fprintf(stderr, "pcl_oracle: %s\n", e.what());
    return 2;
  }
  static const Json empty_params = [] {
    Json j;
    j.kind = Json::Object;
    return j;
  }();
  const Json* params = job.get("params");
  if (!params || params->kind != Json::Object) params = &empty_params;

  Result r;
  r.stage = stage;
  std::string error;
  bool ok = true;
  try {
    if (stage == "load") {
      stage_load(input, repeat, out_dir, r);
    } else if (stage == "rgbd_to_cloud") {
      stage_rgbd(input, *params, repeat, out_dir, r);
    } else if (stage == "region_growing_rgb" || stage == "euclidean") {
      pcl::PCLPointCloud2 blob;
      Eigen::Vector4f origin;
      Eigen::Quaternionf orientation;
      load_blob(input, blob, origin, orientation);
      stage_segment(stage, blob, *params, repeat, r);
    } else {
      pcl::PCLPointCloud2 blob;
      Eigen::Vector4f origin;
      Eigen::Quaternionf orientation;
      load_blob(input, blob, origin, orientation);
      if (has_field(blob, "rgb") || has_field(blob, "rgba"))
        stage_filters<pcl::PointXYZRGBA>(stage, blob, origin, orientation, *params, repeat, out_dir, r);
      else
        stage_filters<pcl::PointXYZ>(stage, blob, origin, orientation, *params, repeat, out_dir, r);
    }
  } catch (const std::exception& e) {
    ok = false;
    error = e.what();
  }
  std::ofstream out(out_dir + "/result.json");
  out << r.to_json(ok, error);
  if (!out) {
    std::fprintf(stderr, "pcl_oracle: cannot write %s/result.json\n", out_dir.c_str());
    return 2;
  }
  if (!ok) std::fprintf(stderr, "pcl_oracle: %s\n", error.c_str());
  return ok ? 0 : 1;
}
