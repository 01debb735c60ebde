// The web viewer's JSON API (server/http/http_api.hpp) without sockets, on a real registry with the
// demo scene: it answers the same messages as the service functions the gRPC handlers call,
// errors as the google.rpc.Status a gRPC client gets, and it honours tokens and limits.
#include "http/http_api.hpp"

#include <chrono>

#include <gmock/gmock.h>
#include <google/protobuf/struct.pb.h>
#include <google/protobuf/util/json_util.h>
#include <google/protobuf/util/message_differencer.h>
#include <google/rpc/error_details.pb.h>
#include <google/rpc/status.pb.h>
#include <gtest/gtest.h>

#include "test_util/time_scale.hpp"

namespace strata::server {
namespace {

using ::testing::HasSubstr;
using ::testing::Not;

constexpr const char* kPlannerToken = "planner-token-0123456789";

// The demo scene as the server preloads it ("demo", 0.2 m) and at 0.1 m ("fine", whose
// geometry needs decimating under 64 KiB), with the services the server would give them.
class HttpApiTest : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    RegistryOptions options;
    options.assessment_threads = 1;
    registry_ = new MapRegistry(options);
    AssessmentConfig fine;
    fine.grid.resolution_m = 0.1;
    for (const auto& [id, config] :
         {std::pair{"demo", AssessmentConfig()}, std::pair{"fine", fine}}) {
      ASSERT_TRUE(
          registry_->Create(id, SceneMapSource{"two_level_ramp", kDefaultSceneSeed, {}}, config)
              .ok());
      const auto done = registry_->WaitUntilDone(
          id, std::chrono::steady_clock::now() + std::chrono::minutes(2), {});
      ASSERT_TRUE(done.ok() && done->state == MapState::kActive) << id;
    }
    slots_ = new PlanningSlots(2, 8, 60.0);
    recent_ = new RecentPlans();
    MapServiceOptions map_options;
    map_options.planning_slots = slots_;
    map_options.max_send_message_bytes = 16 << 20;
    maps_ = new MapServiceImpl(registry_, map_options);
    PlannerServiceOptions planner_options;
    planner_options.slots = slots_;
    planner_options.recent_plans = recent_;
    planner_options.max_samples = 20000;
    planner_ = new PlannerServiceImpl(registry_, nullptr, planner_options);
    reservations_ = new ReservationSchedule(ScheduleLimits{.max_reservations_per_map = 8,
                                                           .default_lease_s = 60,
                                                           .max_lease_s = 600,
                                                           .max_horizon_s = 3600,
                                                           .default_separation_m = 0.1});
    traffic_ = new TrafficServiceImpl(registry_, reservations_, slots_, nullptr);
    tokens_ = new TokenTable({{kPlannerToken, Role::kPlanner}});
  }
  static void TearDownTestSuite() {
    delete tokens_;
    delete traffic_;
    delete reservations_;
    delete planner_;
    delete maps_;
    delete recent_;
    delete slots_;
    delete registry_;
  }

  static HttpResponse Post(const std::string& method, const std::string& body,
                           const TokenTable* tokens = nullptr,
                           const std::string& authorization = "") {
    const HttpApi api(registry_, maps_, planner_, traffic_, tokens);
    return api.Handle(HttpRequest{"POST", "/api/" + method, authorization, body}, CallControl{});
  }

  template <typename Message>
  static Message Parse(const HttpResponse& response) {
    Message message;
    const auto parsed = google::protobuf::util::JsonStringToMessage(response.body, &message);
    EXPECT_TRUE(parsed.ok()) << parsed.message() << "\n" << response.body.substr(0, 500);
    return message;
  }

  // The ErrorInfo of an error body.
  static google::rpc::ErrorInfo InfoOf(const google::rpc::Status& status) {
    google::rpc::ErrorInfo info;
    for (const auto& detail : status.details()) {
      if (detail.UnpackTo(&info)) break;
    }
    return info;
  }

  static std::string PlanJson(const std::string& goal, const std::string& extra = "") {
    return R"({"map_id": "demo", "profile_name": "differential",
               "start": {"position_m": {"x": 2, "y": 2, "z": 0.3}},
               "goal": {"position_m": )" +
           goal + R"(}, "options": {"time_budget_s": 60, "return_search_path": true)" + extra +
           "}}";
  }

  static MapRegistry* registry_;
  static PlanningSlots* slots_;
  static RecentPlans* recent_;
  static MapServiceImpl* maps_;
  static PlannerServiceImpl* planner_;
  static ReservationSchedule* reservations_;
  static TrafficServiceImpl* traffic_;
  static TokenTable* tokens_;
};

MapRegistry* HttpApiTest::registry_ = nullptr;
PlanningSlots* HttpApiTest::slots_ = nullptr;
RecentPlans* HttpApiTest::recent_ = nullptr;
MapServiceImpl* HttpApiTest::maps_ = nullptr;
PlannerServiceImpl* HttpApiTest::planner_ = nullptr;
ReservationSchedule* HttpApiTest::reservations_ = nullptr;
TrafficServiceImpl* HttpApiTest::traffic_ = nullptr;
TokenTable* HttpApiTest::tokens_ = nullptr;

TEST_F(HttpApiTest, ServesThePageFromTheBinary) {
  const HttpApi api(registry_, maps_, planner_, traffic_, tokens_);  // The page needs no token.
  HttpResponse page = api.Handle({"GET", "/", "", ""}, {});
  EXPECT_EQ(page.status, 200);
  EXPECT_THAT(page.content_type, HasSubstr("text/html"));
  EXPECT_THAT(page.body, HasSubstr("<script type=\"module\" src=\"/js/main.js\">"));
  const auto header = [](const HttpResponse& r, const std::string& name) {
    for (const auto& [k, v] : r.headers) {
      if (k == name) return v;
    }
    return std::string();
  };
  EXPECT_THAT(header(page, "Content-Security-Policy"), HasSubstr("default-src 'self'"));
  EXPECT_EQ(header(page, "X-Content-Type-Options"), "nosniff");
  for (const char* path : {"/js/main.js", "/js/api.js", "/js/orbit_view.js", "/viewer.css"}) {
    const HttpResponse asset = api.Handle({"GET", path, "", ""}, {});
    EXPECT_EQ(asset.status, 200) << path;
    EXPECT_GT(asset.body.size(), 100u) << path;
  }
  EXPECT_THAT(api.Handle({"GET", "/js/main.js", "", ""}, {}).content_type,
              HasSubstr("text/javascript"));
  EXPECT_EQ(api.Handle({"GET", "/index.html.bak", "", ""}, {}).status, 404);
  EXPECT_EQ(api.Handle({"GET", "/../server", "", ""}, {}).status, 404);
  EXPECT_EQ(api.Handle({"POST", "/", "", ""}, {}).status, 405);
}

TEST_F(HttpApiTest, AnswersWhatTheServiceFunctionsAnswer) {
  const HttpResponse listed = Post("strata.v1.MapService/ListMaps", "");
  ASSERT_EQ(listed.status, 200) << listed.body;
  // Field names as in the .proto files and the docs, every field printed.
  EXPECT_THAT(listed.body, HasSubstr("\"valid_ground_point_count\""));
  EXPECT_THAT(listed.body, Not(HasSubstr("validGroundPointCount")));
  v1::ListMapsResponse direct;
  ASSERT_TRUE(ListMapsFrom(*registry_, {}, &direct).ok());
  EXPECT_TRUE(google::protobuf::util::MessageDifferencer::Equals(
      Parse<v1::ListMapsResponse>(listed), direct));

  const HttpResponse map = Post("strata.v1.MapService/GetMap", R"({"map_id": "demo"})");
  ASSERT_EQ(map.status, 200);
  EXPECT_EQ(Parse<v1::Map>(map).state(), v1::MAP_STATE_ACTIVE);
  EXPECT_THAT(map.body, HasSubstr("\"MAP_STATE_ACTIVE\""));

  const HttpResponse planned =
      Post("strata.v1.PlannerService/Plan", PlanJson(R"({"x": 10, "y": 10, "z": 3.3})"));
  ASSERT_EQ(planned.status, 200) << planned.body.substr(0, 1000);
  const v1::PlanResponse over_http = Parse<v1::PlanResponse>(planned);
  v1::PlanRequest request;
  ASSERT_TRUE(google::protobuf::util::JsonStringToMessage(
                  PlanJson(R"({"x": 10, "y": 10, "z": 3.3})"), &request)
                  .ok());
  v1::PlanResponse direct_plan;
  ASSERT_TRUE(planner_->PlanOne(request, CallControl{}, "grpc", &direct_plan).ok());
  // Planning is deterministic: the same trajectory either way (timings aside).
  EXPECT_TRUE(google::protobuf::util::MessageDifferencer::Equals(over_http.trajectory(),
                                                                 direct_plan.trajectory()));
  EXPECT_DOUBLE_EQ(over_http.stats().length_m(), direct_plan.stats().length_m());
  EXPECT_EQ(over_http.goal().level(), 1u);
  // The A* path, asked for, runs from the start's cell to the goal's.
  ASSERT_GT(over_http.search_path_m_size(), 10);
  EXPECT_NEAR(over_http.search_path_m(0).x(), 2, 0.1);
  EXPECT_NEAR(over_http.search_path_m(over_http.search_path_m_size() - 1).z(), 3.3, 0.3);

  // Both are among the recent plans, newest first, with how they came.
  const v1::ListRecentPlansResponse recent = Parse<v1::ListRecentPlansResponse>(
      Post("strata.v1.PlannerService/ListRecentPlans", R"({"max_plans": 2})"));
  ASSERT_EQ(recent.plans_size(), 2);
  EXPECT_EQ(recent.plans(0).transport(), "grpc");
  EXPECT_EQ(recent.plans(1).transport(), "http");
  EXPECT_EQ(recent.plans(1).request().map_id(), "demo");
  EXPECT_DOUBLE_EQ(recent.plans(1).response().stats().length_m(), over_http.stats().length_m());
  EXPECT_EQ(recent.plans(1).response().samples_size(), 0);
}

// The viewer's traffic view reads the reservations as a gRPC client would.
TEST_F(HttpApiTest, ListsTheReservationsOfAMap) {
  const auto listed = Parse<v1::ListReservationsResponse>(
      Post("strata.v1.TrafficService/ListReservations", R"({"map_id": "demo"})"));
  EXPECT_EQ(listed.reservations_size(), 0);
  EXPECT_DOUBLE_EQ(listed.separation_m(), 0.1);
  const HttpResponse missing =
      Post("strata.v1.TrafficService/ListReservations", R"({"map_id": "nope"})");
  EXPECT_EQ(missing.status, 404);
  EXPECT_EQ(InfoOf(Parse<google::rpc::Status>(missing)).reason(), "MAP_NOT_FOUND");
}

TEST_F(HttpApiTest, ErrorsAreTheStatusAGrpcClientGets) {
  // Off the ground: 400 with the reason, the field and the nearest valid point.
  const HttpResponse off =
      Post("strata.v1.PlannerService/Plan", PlanJson(R"({"x": 30, "y": 5, "z": 0.3})"));
  EXPECT_EQ(off.status, 400);
  const auto status = Parse<google::rpc::Status>(off);
  EXPECT_EQ(status.code(), 3);  // INVALID_ARGUMENT.
  const google::rpc::ErrorInfo info = InfoOf(status);
  EXPECT_EQ(info.reason(), "GOAL_OFF_GROUND");
  EXPECT_EQ(info.domain(), "strata");
  EXPECT_EQ(info.metadata().at("map_id"), "demo");
  ASSERT_EQ(info.metadata().count("nearest_x_m"), 1u);
  EXPECT_LT(std::stod(info.metadata().at("nearest_x_m")), 30);
  EXPECT_THAT(off.body, HasSubstr("google.rpc.BadRequest"));
  EXPECT_THAT(off.body, HasSubstr("goal.position_m"));
  // The recent plans keep the same error.
  const auto recent = Parse<v1::ListRecentPlansResponse>(
      Post("strata.v1.PlannerService/ListRecentPlans", R"({"max_plans": 1})"));
  ASSERT_EQ(recent.plans_size(), 1);
  EXPECT_EQ(recent.plans(0).error().reason(), "GOAL_OFF_GROUND");
  EXPECT_EQ(recent.plans(0).error().code(), "INVALID_ARGUMENT");
  EXPECT_EQ(recent.plans(0).error().metadata().at("nearest_x_m"),
            info.metadata().at("nearest_x_m"));

  const HttpResponse missing = Post("strata.v1.MapService/GetMap", R"({"map_id": "nope"})");
  EXPECT_EQ(missing.status, 404);
  EXPECT_EQ(InfoOf(Parse<google::rpc::Status>(missing)).reason(), "MAP_NOT_FOUND");

  const HttpResponse bad_json = Post("strata.v1.MapService/GetMap", "{");
  EXPECT_EQ(bad_json.status, 400);
  EXPECT_EQ(InfoOf(Parse<google::rpc::Status>(bad_json)).reason(), "INVALID_INPUT");
  const HttpResponse unknown_field = Post("strata.v1.MapService/GetMap", R"({"mapid": "demo"})");
  EXPECT_EQ(unknown_field.status, 400);
  EXPECT_THAT(unknown_field.body, HasSubstr("strata.v1.GetMapRequest"));

  const HttpApi api(registry_, maps_, planner_, traffic_, nullptr);
  const HttpResponse get = api.Handle({"GET", "/api/strata.v1.MapService/ListMaps", "", ""}, {});
  EXPECT_EQ(get.status, 405);
  const HttpResponse unknown = Post("strata.v1.MapService/DeleteMap", R"({"map_id": "demo"})");
  EXPECT_EQ(unknown.status, 404);  // Read-only but for planning: no map changes here.
  EXPECT_EQ(Parse<google::rpc::Status>(unknown).code(), 12);  // UNIMPLEMENTED, as gRPC.
  EXPECT_TRUE(registry_->Get("demo").ok());

  const HttpResponse too_large = RequestTooLarge(1024);
  EXPECT_EQ(too_large.status, 413);
  EXPECT_EQ(Parse<google::rpc::Status>(too_large).code(), 8);  // RESOURCE_EXHAUSTED.
}

// The page's route answers every call with HTTP 200 and the outcome in the body, so that a
// browser logs no failed load for a refused plan; /api/ keeps the statuses of the mapping.
TEST_F(HttpApiTest, ThePagesRouteCarriesTheOutcomeInTheBody) {
  const HttpApi api(registry_, maps_, planner_, traffic_, nullptr);
  const auto page = [&](const std::string& method, const std::string& body) {
    return api.Handle(HttpRequest{"POST", "/viewer-api/" + method, "", body}, CallControl{});
  };
  const HttpResponse refused = page("strata.v1.MapService/GetMap", R"({"map_id": "nope"})");
  EXPECT_EQ(refused.status, 200);
  google::protobuf::Struct outcome = Parse<google::protobuf::Struct>(refused);
  ASSERT_TRUE(outcome.fields().contains("error"));
  EXPECT_FALSE(outcome.fields().contains("response"));
  std::string error_json;
  ASSERT_TRUE(
      google::protobuf::util::MessageToJsonString(outcome.fields().at("error"), &error_json).ok());
  EXPECT_THAT(error_json, HasSubstr("MAP_NOT_FOUND"));
  EXPECT_EQ(Post("strata.v1.MapService/GetMap", R"({"map_id": "nope"})").status, 404);

  const HttpResponse answered = page("strata.v1.MapService/GetMap", R"({"map_id": "demo"})");
  EXPECT_EQ(answered.status, 200);
  outcome = Parse<google::protobuf::Struct>(answered);
  ASSERT_TRUE(outcome.fields().contains("response"));
  EXPECT_EQ(outcome.fields().at("response").struct_value().fields().at("id").string_value(),
            "demo");
}

TEST_F(HttpApiTest, TokensAreCheckedAsForGrpc) {
  const HttpResponse none = Post("strata.v1.MapService/ListMaps", "", tokens_);
  EXPECT_EQ(none.status, 401);
  EXPECT_EQ(InfoOf(Parse<google::rpc::Status>(none)).reason(), "UNAUTHENTICATED");
  EXPECT_EQ(
      Post("strata.v1.MapService/ListMaps", "", tokens_, "Bearer wrong-token-0123456789").status,
      401);
  EXPECT_EQ(
      Post("strata.v1.MapService/ListMaps", "", tokens_, std::string("Bearer ") + kPlannerToken)
          .status,
      200);
}

TEST_F(HttpApiTest, GeometryFitsItsBytesAndCarriesTheRobotsComponents) {
  const auto geometry = [](const std::string& body) {
    return Post("strata.v1.MapService/GetMapGeometry", body);
  };
  const HttpResponse full = geometry(R"({"map_id": "fine", "include_safety": true})");
  ASSERT_EQ(full.status, 200) << full.body.substr(0, 500);
  const auto whole = Parse<v1::MapGeometry>(full);
  EXPECT_EQ(whole.stride(), 1u);
  EXPECT_EQ(whole.max_levels(), 2u);
  EXPECT_EQ(whole.ground_safety_size(), whole.ground_z_m_size());
  EXPECT_DOUBLE_EQ(whole.safety_height_m(), 0.3);
  EXPECT_FALSE(whole.map_version().empty());
  ASSERT_GT(whole.ByteSizeLong(), 65536u) << "the test needs a map above the smallest max_bytes";

  // Stride 0 picks one that fits.
  const auto fitted = Parse<v1::MapGeometry>(geometry(R"({"map_id": "fine", "max_bytes": 65536})"));
  EXPECT_GT(fitted.stride(), 1u);
  EXPECT_LE(fitted.ByteSizeLong(), 65536u);
  // A stride asked for that does not fit is refused, naming a larger one to ask for.
  std::uint32_t stride = 1;
  HttpResponse asked;
  for (int attempt = 0; attempt < 5; ++attempt) {
    asked = geometry(R"({"map_id": "fine", "max_bytes": 65536, "stride": )" +
                     std::to_string(stride) + "}");
    if (asked.status == 200) break;
    ASSERT_EQ(asked.status, 429) << asked.body;
    EXPECT_EQ(InfoOf(Parse<google::rpc::Status>(asked)).reason(), "RESOURCE_EXHAUSTED");
    const std::size_t at = asked.body.find("ask for stride ");
    ASSERT_NE(at, std::string::npos) << asked.body;
    const auto named = static_cast<std::uint32_t>(std::stoul(asked.body.substr(at + 15)));
    EXPECT_GT(named, stride);
    stride = named;
  }
  ASSERT_EQ(asked.status, 200);
  EXPECT_EQ(Parse<v1::MapGeometry>(asked).stride(), stride);
  EXPECT_LE(Parse<v1::MapGeometry>(asked).ByteSizeLong(), 65536u);

  // A robot: every ground surface labelled, and its traversable ones connected.
  const auto robot =
      Parse<v1::MapGeometry>(geometry(R"({"map_id": "fine", "profile_name": "differential"})"));
  ASSERT_EQ(robot.ground_component_size(), robot.ground_z_m_size());
  int labelled = 0;
  for (const int component : robot.ground_component()) labelled += component >= 0 ? 1 : 0;
  EXPECT_GT(labelled, robot.ground_z_m_size() / 2);

  EXPECT_EQ(geometry(R"({"map_id": "fine", "max_bytes": 10})").status, 400);
  EXPECT_EQ(geometry(R"({"map_id": "fine", "stride": 1000})").status, 400);
  EXPECT_EQ(geometry(R"({"map_id": "fine", "profile_name": "tank"})").status, 400);
}

}  // namespace
}  // namespace strata::server
