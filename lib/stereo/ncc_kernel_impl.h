// The correlation kernel, written once with OpenCV universal intrinsics (vx_ types of the
// widest width the translation unit is compiled for). Included by ncc_kernel_baseline.cc
// and ncc_kernel_avx2.cc inside a namespace of their own. Everything here has internal
// linkage and uses no standard-library templates, so the AVX2 copy never leaks into the
// portable code through the linker.
//
// Algorithm (Krotkov & Hebert sec. 3.2 and 3.4). For an output row y, column sums
//   col[i][k] = sum_{j=-my..my} R(x_i, y + j*dy) * T(x_i + d_min + k, y + j*dy)
// are kept for every grid column x_i and disparity index k (k contiguous, so the updates
// vectorise across disparities), and updated recursively from row to row: add the products
// of the row entering the window, subtract those of the row leaving it, both at once with
// one int16 multiply-add (v_dotprod) on interleaved pairs of target rows. The window sum is
// then the paper's recursion over grid columns, S(x+dx) = S(x) + S_y(x+(mx+1)dx) - S_y(x-mx*dx).
// With the window means and variances (also running sums) the correlation
//   C = (S - Sum_r Sum_t / n) / (n sigma_r sigma_t)
// is evaluated for every k in float for the search, and exactly (double, from the integer
// sums) at the best disparity and its two neighbours.

namespace {

constexpr int kLanes = cv::v_int32::nlanes;
constexpr float kNegInf = -__builtin_inff();

inline int MinInt(int a, int b) { return a < b ? a : b; }
inline int MaxInt(int a, int b) { return a > b ? a : b; }

struct Workspace {
  std::int32_t* col;      // num_cols x Dp column sums of products
  std::int32_t* sum;      // Dp window sums of products, current grid column
  float* curve;           // Dp + 2 (sentinels at both ends): float correlation curve
  std::int16_t* pairs;    // 2 * Wp interleaved target rows (zero padded)
  std::int64_t* t_col1;   // width: vertical sums of T at each column
  std::int64_t* t_col2;   // width: vertical sums of T^2
  std::int64_t* r_col1;   // width
  std::int64_t* r_col2;   // width
  std::int64_t* prefix1;  // width: strided prefix sums (scratch)
  std::int64_t* prefix2;  // width
  std::int64_t* t_sum;    // Wp: window sum of T at padded column p (0 outside)
  std::int64_t* t_var;    // Wp: n*sum(T^2) - sum(T)^2 (0 outside)
  float* t_sumf;          // Wp: float(t_sum)
  float* t_k;             // Wp: sqrt(n / t_var), 0 where undefined
  std::int64_t* r_sum;    // width
  std::int64_t* r_var;    // width
};

inline std::size_t AlignUp(std::size_t bytes) { return (bytes + 63) / 64 * 64; }

struct Geometry {
  int dp;      // padded disparities
  int xa;      // leftmost target column represented in padded arrays (<= 0)
  int wp;      // padded width
  int n;       // pixels in the subsampled window
  int half_x;  // mx * dx, half window in pixels
};

inline Geometry MakeGeometry(const lunarnav::stereo::internal::KernelInput& in) {
  Geometry g;
  g.dp = lunarnav::stereo::internal::PaddedDisparities(in.num_disp);
  g.xa = MinInt(0, in.d_min);
  const int xb = MaxInt(in.width - 1, in.width - 1 + in.d_min + g.dp - 1);
  g.wp = xb - g.xa + 1;
  g.n = (2 * in.mx + 1) * (2 * in.my + 1);
  g.half_x = in.mx * in.step_x;
  return g;
}

// Carves the workspace; returns the bytes used (for KernelWorkspaceBytes with base == nullptr).
inline std::size_t LayoutWorkspace(const lunarnav::stereo::internal::KernelInput& in,
                                   const Geometry& g, unsigned char* base, Workspace* ws) {
  std::size_t offset = 0;
  auto take = [&](std::size_t bytes) -> unsigned char* {
    unsigned char* p = base == nullptr ? nullptr : base + offset;
    offset += AlignUp(bytes);
    return p;
  };
  const std::size_t w = static_cast<std::size_t>(in.width);
  const std::size_t wp = static_cast<std::size_t>(g.wp);
  ws->col = reinterpret_cast<std::int32_t*>(
      take(sizeof(std::int32_t) * static_cast<std::size_t>(in.num_cols) * g.dp));
  ws->sum = reinterpret_cast<std::int32_t*>(take(sizeof(std::int32_t) * g.dp));
  ws->curve = reinterpret_cast<float*>(take(sizeof(float) * (g.dp + 2 + 16)));
  ws->pairs = reinterpret_cast<std::int16_t*>(take(sizeof(std::int16_t) * (2 * wp + 64)));
  ws->t_col1 = reinterpret_cast<std::int64_t*>(take(sizeof(std::int64_t) * w));
  ws->t_col2 = reinterpret_cast<std::int64_t*>(take(sizeof(std::int64_t) * w));
  ws->r_col1 = reinterpret_cast<std::int64_t*>(take(sizeof(std::int64_t) * w));
  ws->r_col2 = reinterpret_cast<std::int64_t*>(take(sizeof(std::int64_t) * w));
  ws->prefix1 = reinterpret_cast<std::int64_t*>(take(sizeof(std::int64_t) * w));
  ws->prefix2 = reinterpret_cast<std::int64_t*>(take(sizeof(std::int64_t) * w));
  ws->t_sum = reinterpret_cast<std::int64_t*>(take(sizeof(std::int64_t) * wp));
  ws->t_var = reinterpret_cast<std::int64_t*>(take(sizeof(std::int64_t) * wp));
  ws->t_sumf = reinterpret_cast<float*>(take(sizeof(float) * (wp + 16)));
  ws->t_k = reinterpret_cast<float*>(take(sizeof(float) * (wp + 16)));
  ws->r_sum = reinterpret_cast<std::int64_t*>(take(sizeof(std::int64_t) * w));
  ws->r_var = reinterpret_cast<std::int64_t*>(take(sizeof(std::int64_t) * w));
  return offset;
}

// Vertical sums of v and v^2 over the window rows y + j*dy, j = -my..my, for every column.
inline void InitColumnStats(const std::int16_t* img, int width, int y, int dy, int my,
                            std::int64_t* c1, std::int64_t* c2) {
  for (int x = 0; x < width; ++x) c1[x] = c2[x] = 0;
  for (int j = -my; j <= my; ++j) {
    const std::int16_t* row = img + static_cast<std::ptrdiff_t>(y + j * dy) * width;
    for (int x = 0; x < width; ++x) {
      const std::int64_t v = row[x];
      c1[x] += v;
      c2[x] += v * v;
    }
  }
}

// Moves the vertical sums from the window of row y to that of row y + dy.
inline void UpdateColumnStats(const std::int16_t* img, int width, int y, int dy, int my,
                              std::int64_t* c1, std::int64_t* c2) {
  const std::int16_t* enter = img + static_cast<std::ptrdiff_t>(y + (my + 1) * dy) * width;
  const std::int16_t* leave = img + static_cast<std::ptrdiff_t>(y - my * dy) * width;
  for (int x = 0; x < width; ++x) {
    const std::int64_t a = enter[x], b = leave[x];
    c1[x] += a - b;
    c2[x] += a * a - b * b;
  }
}

// Window sums over columns x + j*dx, j = -mx..mx, from the vertical sums, by strided prefix
// sums; writes sum and V = n*sum(v^2) - sum(v)^2 at out[x + out_offset] for every column x
// whose window is inside the image, and 0 elsewhere in [0, width).
inline void WindowStats(const std::int64_t* c1, const std::int64_t* c2, int width, int dx,
                        int mx, int n, std::int64_t* p1, std::int64_t* p2, std::int64_t* out_sum,
                        std::int64_t* out_var, int out_offset) {
  for (int x = 0; x < width; ++x) {
    p1[x] = c1[x] + (x >= dx ? p1[x - dx] : 0);
    p2[x] = c2[x] + (x >= dx ? p2[x - dx] : 0);
  }
  const int half = mx * dx;
  for (int x = 0; x < width; ++x) {
    std::int64_t s = 0, v = 0;
    if (x >= half && x + half < width) {
      const int before = x - (mx + 1) * dx;
      s = p1[x + half] - (before >= 0 ? p1[before] : 0);
      const std::int64_t s2 = p2[x + half] - (before >= 0 ? p2[before] : 0);
      v = static_cast<std::int64_t>(n) * s2 - s * s;
    }
    out_sum[x + out_offset] = s;
    out_var[x + out_offset] = v;
  }
}

// col[i][k] += ca * T(row_a, x_i + d_min + k) + cb * T(row_b, x_i + d_min + k) for every grid
// column i, from `pairs` holding the two target rows interleaved.
inline void AccumulateProducts(const lunarnav::stereo::internal::KernelInput& in, const Geometry& g,
                               const Workspace& ws, const std::int16_t* ref_a, const std::int16_t* ref_b,
                               int sign_b) {
  for (int i = 0; i < in.num_cols; ++i) {
    const int x = in.x0 + i * in.step_x;
    const std::int16_t ca = ref_a[x];
    const std::int16_t cb = static_cast<std::int16_t>(sign_b * ref_b[x]);
    const std::uint32_t packed = static_cast<std::uint16_t>(ca) |
                                 (static_cast<std::uint32_t>(static_cast<std::uint16_t>(cb)) << 16);
    const cv::v_int16 coef = cv::v_reinterpret_as_s16(cv::vx_setall_u32(packed));
    std::int32_t* col = ws.col + static_cast<std::ptrdiff_t>(i) * g.dp;
    const std::int16_t* src = ws.pairs + 2 * (x + in.d_min - g.xa);
    for (int k = 0; k < g.dp; k += kLanes) {
      const cv::v_int32 acc = cv::vx_load(col + k) + cv::v_dotprod(cv::vx_load(src + 2 * k), coef);
      cv::v_store(col + k, acc);
    }
  }
}

// Interleaves target rows a and b into ws.pairs (padding stays zero).
inline void InterleaveRows(const std::int16_t* a, const std::int16_t* b, int width, int xa,
                           std::int16_t* pairs) {
  std::int16_t* dst = pairs + 2 * (0 - xa);
  for (int x = 0; x < width; ++x) {
    dst[2 * x] = a[x];
    dst[2 * x + 1] = b[x];
  }
}

inline double ExactC(std::int64_t n, std::int64_t s, std::int64_t r_sum, std::int64_t r_var,
                     std::int64_t t_sum, std::int64_t t_var) {
  if (r_var <= 0 || t_var <= 0) return 0.0;
  const double num = static_cast<double>(n) * static_cast<double>(s) -
                     static_cast<double>(r_sum) * static_cast<double>(t_sum);
  return num / __builtin_sqrt(static_cast<double>(r_var) * static_cast<double>(t_var));
}

// Searches the disparities of one grid pixel whose window sums of products are in ws.sum.
inline void SearchPixel(const lunarnav::stereo::internal::KernelInput& in, const Geometry& g,
                        const Workspace& ws, int x, lunarnav::stereo::internal::PeakRecord* rec) {
  using lunarnav::stereo::internal::PeakRecord;
  const std::int64_t r_var = ws.r_var[x];
  const std::int64_t r_sum = ws.r_sum[x];
  if (r_var <= 0 || static_cast<double>(r_var) < in.min_var) {
    rec->status = PeakRecord::kLowTexture;
    return;
  }
  // Searchable indices: the target window x + d_min + k +- half_x stays inside the image.
  const int lo = MaxInt(0, g.half_x - x - in.d_min);
  const int hi = MinInt(in.num_disp - 1, in.width - 1 - g.half_x - x - in.d_min);
  rec->lo = static_cast<std::int16_t>(lo);
  rec->hi = static_cast<std::int16_t>(hi);
  if (lo > hi) {
    rec->status = PeakRecord::kBorder;
    return;
  }
  rec->status = PeakRecord::kSearched;

  // Float correlation curve over all padded disparities.
  const int base = x + in.d_min - g.xa;  // padded column of k = 0
  const float n_f = static_cast<float>(g.n);
  const float a_r = static_cast<float>(r_sum) / n_f;
  const float k_r = static_cast<float>(__builtin_sqrt(static_cast<double>(g.n) / static_cast<double>(r_var)));
  const cv::v_float32 va = cv::vx_setall_f32(a_r);
  const cv::v_float32 vk = cv::vx_setall_f32(k_r);
  float* curve = ws.curve + 1;  // curve[-1] and curve[dp] are sentinels
  for (int k = 0; k < g.dp; k += kLanes) {
    const cv::v_float32 s = cv::v_cvt_f32(cv::vx_load(ws.sum + k));
    const cv::v_float32 num = s - va * cv::vx_load(ws.t_sumf + base + k);
    cv::v_store(curve + k, num * vk * cv::vx_load(ws.t_k + base + k));
  }
  for (int k = 0; k < lo; ++k) curve[k] = kNegInf;
  for (int k = hi + 1; k < g.dp; ++k) curve[k] = kNegInf;
  curve[-1] = kNegInf;
  curve[g.dp] = kNegInf;

  // Peaks (strictly above the left neighbour, not below the right one): per lane, the two
  // highest peak values.
  cv::v_float32 top1 = cv::vx_setall_f32(kNegInf), top2 = top1;
  const cv::v_float32 neg = top1;
  for (int k = 0; k < g.dp; k += kLanes) {
    const cv::v_float32 c = cv::vx_load(curve + k);
    const cv::v_float32 is_peak = (c > cv::vx_load(curve + k - 1)) & (c >= cv::vx_load(curve + k + 1));
    const cv::v_float32 v = cv::v_select(is_peak, c, neg);
    top2 = cv::v_max(top2, cv::v_min(top1, v));
    top1 = cv::v_max(top1, v);
  }
  float t1[kLanes], t2[kLanes];
  cv::v_store(t1, top1);
  cv::v_store(t2, top2);
  float best = kNegInf;
  int best_lane = 0;
  for (int l = 0; l < kLanes; ++l) {
    if (t1[l] > best) { best = t1[l]; best_lane = l; }
  }
  float second = kNegInf;
  for (int l = 0; l < kLanes; ++l) {
    if (t2[l] > second) second = t2[l];
    if (l != best_lane && t1[l] > second) second = t1[l];
  }
  // First index of the best value (the global maximum is always a peak).
  int best_k = lo;
  const cv::v_float32 vbest = cv::vx_setall_f32(best);
  for (int k = 0; k < g.dp; k += kLanes) {
    const int mask = cv::v_signmask(cv::vx_load(curve + k) == vbest);
    if (mask != 0) {
      best_k = k + __builtin_ctz(static_cast<unsigned>(mask));
      break;
    }
  }
  rec->best = static_cast<std::int16_t>(best_k);
  rec->c_second = second;
  const std::int64_t n = g.n;
  auto exact = [&](int k) {
    return static_cast<float>(ExactC(n, ws.sum[k], r_sum, r_var, ws.t_sum[base + k], ws.t_var[base + k]));
  };
  rec->c_best = exact(best_k);
  rec->c_prev = best_k > lo ? exact(best_k - 1) : 0.0f;
  rec->c_next = best_k < hi ? exact(best_k + 1) : 0.0f;
}

void RunKernelImpl(const lunarnav::stereo::internal::KernelInput& in, int row_begin, int row_end,
                   void* workspace, lunarnav::stereo::internal::PeakRecord* records) {
  using lunarnav::stereo::internal::PeakRecord;
  const Geometry g = MakeGeometry(in);
  Workspace ws;
  LayoutWorkspace(in, g, static_cast<unsigned char*>(workspace), &ws);
  const int width = in.width;
  const int dy = in.step_y, my = in.my;
  for (int p = 0; p < 2 * g.wp + 64; ++p) ws.pairs[p] = 0;
  for (int p = 0; p < g.wp + 16; ++p) ws.t_sumf[p] = ws.t_k[p] = 0.0f;
  for (int p = 0; p < g.wp; ++p) ws.t_sum[p] = ws.t_var[p] = 0;
  auto ref_row = [&](int y) { return in.ref + static_cast<std::ptrdiff_t>(y) * width; };
  auto tgt_row = [&](int y) { return in.tgt + static_cast<std::ptrdiff_t>(y) * width; };

  // Grid columns whose window is inside the image.
  int i_lo = 0;
  while (i_lo < in.num_cols && in.x0 + i_lo * in.step_x < g.half_x) ++i_lo;
  int i_hi = in.num_cols - 1;
  while (i_hi >= 0 && in.x0 + i_hi * in.step_x + g.half_x > width - 1) --i_hi;

  for (int j = row_begin; j < row_end; ++j) {
    const int y = in.first_row + j * dy;
    if (j == row_begin) {
      for (std::size_t q = 0; q < static_cast<std::size_t>(in.num_cols) * g.dp; ++q) ws.col[q] = 0;
      for (int r = -my; r <= my; r += 2) {
        const int ya = y + r * dy;
        const int yb = r + 1 <= my ? ya + dy : ya;  // odd count: pair the last row with itself, weight 0
        InterleaveRows(tgt_row(ya), tgt_row(yb), width, g.xa, ws.pairs);
        AccumulateProducts(in, g, ws, ref_row(ya), ref_row(yb), r + 1 <= my ? 1 : 0);
      }
      InitColumnStats(in.tgt, width, y, dy, my, ws.t_col1, ws.t_col2);
      InitColumnStats(in.ref, width, y, dy, my, ws.r_col1, ws.r_col2);
    } else {
      const int y_prev = y - dy;
      const int enter = y_prev + (my + 1) * dy, leave = y_prev - my * dy;
      InterleaveRows(tgt_row(enter), tgt_row(leave), width, g.xa, ws.pairs);
      AccumulateProducts(in, g, ws, ref_row(enter), ref_row(leave), -1);
      UpdateColumnStats(in.tgt, width, y_prev, dy, my, ws.t_col1, ws.t_col2);
      UpdateColumnStats(in.ref, width, y_prev, dy, my, ws.r_col1, ws.r_col2);
    }
    WindowStats(ws.t_col1, ws.t_col2, width, in.step_x, in.mx, g.n, ws.prefix1, ws.prefix2,
                ws.t_sum, ws.t_var, -g.xa);
    for (int p = 0; p < g.wp; ++p) {
      ws.t_sumf[p] = static_cast<float>(ws.t_sum[p]);
      ws.t_k[p] = ws.t_var[p] > 0
                      ? static_cast<float>(__builtin_sqrt(static_cast<double>(g.n) / static_cast<double>(ws.t_var[p])))
                      : 0.0f;
    }
    WindowStats(ws.r_col1, ws.r_col2, width, in.step_x, in.mx, g.n, ws.prefix1, ws.prefix2,
                ws.r_sum, ws.r_var, 0);

    PeakRecord* row_records = records + static_cast<std::ptrdiff_t>(j) * in.num_cols;
    for (int i = 0; i < in.num_cols; ++i) row_records[i] = PeakRecord{};
    if (i_lo > i_hi) continue;
    // Window sums of products at grid column i_lo, then the recursion over grid columns.
    for (int k = 0; k < g.dp; k += kLanes) {
      cv::v_int32 acc = cv::vx_setzero_s32();
      for (int q = i_lo - in.mx; q <= i_lo + in.mx; ++q) {
        acc = acc + cv::vx_load(ws.col + static_cast<std::ptrdiff_t>(q) * g.dp + k);
      }
      cv::v_store(ws.sum + k, acc);
    }
    for (int i = i_lo; i <= i_hi; ++i) {
      if (i > i_lo) {
        const std::int32_t* add = ws.col + static_cast<std::ptrdiff_t>(i + in.mx) * g.dp;
        const std::int32_t* sub = ws.col + static_cast<std::ptrdiff_t>(i - in.mx - 1) * g.dp;
        for (int k = 0; k < g.dp; k += kLanes) {
          cv::v_store(ws.sum + k, cv::vx_load(ws.sum + k) + cv::vx_load(add + k) - cv::vx_load(sub + k));
        }
      }
      SearchPixel(in, g, ws, in.x0 + i * in.step_x, &row_records[i]);
    }
  }
}

}  // namespace
