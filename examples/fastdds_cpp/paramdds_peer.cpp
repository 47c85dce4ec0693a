// A paramdds participant in C++ on eProsima Fast DDS 2.x (Debian's 2.9.1 is enough), built
// from idl/paramdds.idl with fastddsgen at build time. No paramdds code: only the IDL and
// the QoS profiles of qos/DDS_QOS_PROFILES.xml, written out below.
//
//   paramdds_peer node NODE_ID            host four parameters; answer get/list/set
//   paramdds_peer monitor [SECONDS]       late-join ParameterEvents and print every node's state
//   paramdds_peer get NODE NAME...        ask a node for values
//   paramdds_peer set NODE NAME=VALUE...  (VALUE: true/false, an integer, a double, else a string)
//   paramdds_peer list NODE
//
// Domain: $PARAMDDS_DOMAIN (default 1). With PARAMDDS_LOCALHOST=1: UDPv4 on 127.0.0.1 only,
// discovery by unicast to 127.0.0.1 (participant indices 0..119), as paramdds --localhost.
// Output and exit status: as examples/cyclone_c/paramdds_peer.c, and so is blame: each
// parameter's state says who changed it and through what, as the asker claimed them
// (unverified); its start values are its own ($PARAMDDS_AS, else USER@host, via "start",
// verified: no claim crossed a wire); a set
// it sends says the same identity, via "api". The node keeps no history: a history query is
// answered as a get, history_kept FALSE.

#include <fastdds/dds/domain/DomainParticipant.hpp>
#include <fastdds/dds/domain/DomainParticipantFactory.hpp>
#include <fastdds/dds/publisher/DataWriter.hpp>
#include <fastdds/dds/publisher/Publisher.hpp>
#include <fastdds/dds/subscriber/DataReader.hpp>
#include <fastdds/dds/subscriber/SampleInfo.hpp>
#include <fastdds/dds/subscriber/Subscriber.hpp>
#include <fastdds/dds/topic/TypeSupport.hpp>
#include <fastdds/rtps/transport/UDPv4TransportDescriptor.h>
#include <fastrtps/utils/IPLocator.h>

#include <unistd.h>

#include <chrono>
#include <csignal>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <ctime>
#include <deque>
#include <random>
#include <string>
#include <thread>
#include <vector>

#include "paramddsPubSubTypes.h"

using namespace eprosima::fastdds::dds;
using eprosima::fastrtps::Duration_t;
using Clock = std::chrono::steady_clock;

// nanoseconds since the Unix epoch by this host's clock (a set request's deadline is one)
static int64_t wall_ns()
{
    return std::chrono::duration_cast<std::chrono::nanoseconds>(std::chrono::system_clock::now().time_since_epoch())
        .count();
}

// $PARAMDDS_AS, else USER@host: the identity this program claims (as paramdds's default)
static std::string local_identity()
{
    const char *as = std::getenv("PARAMDDS_AS");
    if (as && *as)
        return as;
    const char *user = std::getenv("USER");
    char host[128] = {0};
    gethostname(host, sizeof(host) - 1);
    return std::string(user && *user ? user : "unknown") + "@" + host;
}

static const char *TYPE_NAMES[] = {"not_set", "bool", "integer", "double", "string", "byte_array",
                                   "bool_array", "integer_array", "double_array", "string_array"};

// ---- QoS: the profiles of qos/DDS_QOS_PROFILES.xml ------------------------------------------

template <typename Q> static void reliable(Q &q, DurabilityQosPolicyKind durability)
{
    q.reliability().kind = RELIABLE_RELIABILITY_QOS;
    q.reliability().max_blocking_time = Duration_t(1, 0);
    q.durability().kind = durability;
}

static void heartbeat(DataWriterQos &q)
{
    // Fast DDS announces a writer's data every 3 s by default: a late joiner (a monitor, or a
    // client whose first reply was sent before it matched) would wait that long.
    q.reliable_writer_qos().times.heartbeatPeriod = Duration_t(0, 100000000);
}

static DataWriterQos state_writer_qos()
{
    DataWriterQos q = DATAWRITER_QOS_DEFAULT;
    reliable(q, TRANSIENT_LOCAL_DURABILITY_QOS);
    heartbeat(q);
    q.history().kind = KEEP_LAST_HISTORY_QOS;
    q.history().depth = 1;
    q.resource_limits().max_instances = 1000;
    q.resource_limits().max_samples_per_instance = 1;
    q.resource_limits().max_samples = 1000;
    // No writer liveliness lease (the State profile has 1 s): Fast DDS 2.9 asserts it with
    // participant messages that Cyclone 11 cannot parse and logs on every assertion. A killed
    // node is seen offline through the short participant lease instead (see Dds()).
    q.writer_data_lifecycle().autodispose_unregistered_instances = false;  // a stop is not a delete
    return q;
}

static DataReaderQos state_reader_qos()
{
    DataReaderQos q = DATAREADER_QOS_DEFAULT;
    reliable(q, TRANSIENT_LOCAL_DURABILITY_QOS);
    q.history().kind = KEEP_LAST_HISTORY_QOS;
    q.history().depth = 1;
    q.resource_limits().max_instances = 100000;  // one per parameter of every node
    q.resource_limits().max_samples_per_instance = 1;
    q.resource_limits().max_samples = 100000;
    return q;
}

// Request and Reply: reliable, volatile; writers keep a deep history, readers keep all.
static DataWriterQos call_writer_qos()
{
    DataWriterQos q = DATAWRITER_QOS_DEFAULT;
    reliable(q, VOLATILE_DURABILITY_QOS);
    heartbeat(q);
    q.history().kind = KEEP_LAST_HISTORY_QOS;
    q.history().depth = 4096;
    q.resource_limits().max_instances = 16;
    q.resource_limits().max_samples_per_instance = 4096;
    q.resource_limits().max_samples = 4096 * 16;
    return q;
}

static DataReaderQos call_reader_qos()
{
    DataReaderQos q = DATAREADER_QOS_DEFAULT;
    reliable(q, VOLATILE_DURABILITY_QOS);
    q.history().kind = KEEP_ALL_HISTORY_QOS;
    q.resource_limits().max_instances = 0;  // 0: unlimited (one instance per node id asked about)
    q.resource_limits().max_samples_per_instance = 0;
    q.resource_limits().max_samples = 0;
    return q;
}

// ---- entities ---------------------------------------------------------------------------------

static void fail(const std::string &what)
{
    std::fprintf(stderr, "paramdds_peer: %s\n", what.c_str());
    std::exit(4);
}

struct Dds
{
    DomainParticipant *dp = nullptr;
    Publisher *pub = nullptr;
    Subscriber *sub = nullptr;

    Dds()
    {
        const char *domain = std::getenv("PARAMDDS_DOMAIN");
        DomainParticipantQos pq = PARTICIPANT_QOS_DEFAULT;
        pq.name("paramdds_peer_fastdds");
        pq.wire_protocol().builtin.discovery_config.leaseDuration = Duration_t(2, 0);  // killed: offline in ~2 s
        pq.wire_protocol().builtin.discovery_config.leaseDuration_announcementperiod = Duration_t(0, 500000000);
        const char *local = std::getenv("PARAMDDS_LOCALHOST");
        if (local && (std::string(local) == "1" || std::string(local) == "true"))
        {
            auto udp = std::make_shared<eprosima::fastdds::rtps::UDPv4TransportDescriptor>();
            udp->interfaceWhiteList.push_back("127.0.0.1");
            udp->maxInitialPeersRange = 120;  // the ports of participant indices 0..119
            pq.transport().use_builtin_transports = false;
            pq.transport().user_transports.push_back(udp);
            eprosima::fastrtps::rtps::Locator_t peer;
            eprosima::fastrtps::rtps::IPLocator::setIPv4(peer, 127, 0, 0, 1);
            pq.wire_protocol().builtin.initialPeersList.push_back(peer);
        }
        dp = DomainParticipantFactory::get_instance()->create_participant(domain ? std::atoi(domain) : 1, pq);
        if (!dp)
            fail("cannot create a participant");
        pub = dp->create_publisher(PUBLISHER_QOS_DEFAULT);
        sub = dp->create_subscriber(SUBSCRIBER_QOS_DEFAULT);
    }

    ~Dds()
    {
        dp->delete_contained_entities();  // peers see the node's instances with no writers
        DomainParticipantFactory::get_instance()->delete_participant(dp);
    }

    Topic *topic(const char *name, TopicDataType *type)
    {
        TypeSupport support(type);
        support.register_type(dp);
        Topic *t = dp->create_topic(name, support.get_type_name(), TOPIC_QOS_DEFAULT);
        if (!t)
            fail(std::string("cannot create topic ") + name);
        return t;
    }

    DataWriter *writer(const char *name, TopicDataType *type, const DataWriterQos &q)
    {
        DataWriter *w = pub->create_datawriter(topic(name, type), q);
        if (!w)
            fail(std::string("cannot create a writer on ") + name);
        return w;
    }

    DataReader *reader(const char *name, TopicDataType *type, const DataReaderQos &q)
    {
        DataReader *r = sub->create_datareader(topic(name, type), q);
        if (!r)
            fail(std::string("cannot create a reader on ") + name);
        return r;
    }
};

// ---- values -----------------------------------------------------------------------------------

static void print_json_string(const std::string &s)
{
    std::putchar('"');
    for (unsigned char c : s)
    {
        if (c == '"' || c == '\\')
            std::printf("\\%c", c);
        else if (c < 0x20)
            std::printf("\\u%04x", c);
        else
            std::putchar(c);
    }
    std::putchar('"');
}

template <typename T, typename F> static void print_list(const std::vector<T> &v, F each)
{
    std::putchar('[');
    for (size_t i = 0; i < v.size(); i++)
    {
        if (i)
            std::putchar(',');
        each(v[i]);
    }
    std::putchar(']');
}

static void print_value(const paramdds::ParameterValue &v)
{
    std::printf("%s ", v.type() < 10 ? TYPE_NAMES[v.type()] : "unknown");
    switch (v.type())
    {
    case 1: std::printf("%s", v.bool_value() ? "true" : "false"); break;
    case 2: std::printf("%lld", static_cast<long long>(v.integer_value())); break;
    case 3: std::printf("%.17g", v.double_value()); break;
    case 4: print_json_string(v.string_value()); break;
    case 5: print_list(v.byte_array_value(), [](uint8_t x) { std::printf("%u", x); }); break;
    case 6: print_list(v.bool_array_value(), [](bool x) { std::printf("%s", x ? "true" : "false"); }); break;
    case 7: print_list(v.integer_array_value(), [](int64_t x) { std::printf("%lld", static_cast<long long>(x)); }); break;
    case 8: print_list(v.double_array_value(), [](double x) { std::printf("%.17g", x); }); break;
    case 9: print_list(v.string_array_value(), [](const std::string &x) { print_json_string(x); }); break;
    default: std::printf("null"); break;
    }
}

// "true"/"false", an integer, a double, else a string
static paramdds::ParameterValue parse_value(const std::string &text)
{
    paramdds::ParameterValue v;
    char *end = nullptr;
    if (text == "true" || text == "false")
    {
        v.type(1);
        v.bool_value(text == "true");
        return v;
    }
    long long i = std::strtoll(text.c_str(), &end, 10);
    if (!text.empty() && *end == '\0')
    {
        v.type(2);
        v.integer_value(i);
        return v;
    }
    double d = std::strtod(text.c_str(), &end);
    if (!text.empty() && *end == '\0')
    {
        v.type(3);
        v.double_value(d);
        return v;
    }
    v.type(4);
    v.string_value(text);
    return v;
}

// ---- node -------------------------------------------------------------------------------------

static volatile std::sig_atomic_t stop_requested = 0;

static uint64_t new_incarnation()
{
    std::random_device rd;
    uint64_t x = (static_cast<uint64_t>(rd()) << 32) ^ rd();
    return x ? x : 1;
}

// who last changed a parameter, through what, when, at which revision; verified: the node's own
// start value (no claim crossed a wire), not a set's asker, who only claims
struct Blame
{
    std::string who, via;
    bool verified = false;
    paramdds::Time stamp;
    int64_t revision = 0;
};

struct Node
{
    std::string id;
    std::vector<paramdds::Parameter> params;
    std::vector<Blame> blame;  // one per parameter, in the same order
    int64_t revision = 1;
    // random, non-zero, new on every start: (incarnation, revision) never repeats
    uint64_t incarnation = new_incarnation();
    DataWriter *state = nullptr;
    std::string host;
    // the last answers to sets: a resent set (same client_id and request_id) gets its first
    // answer again and is not applied twice (clients resend while discovery settles)
    std::deque<paramdds::SetParametersResponse> answered;
    static constexpr size_t ANSWERED = 64;

    paramdds::Parameter *find(const std::string &name)
    {
        for (auto &p : params)
            if (p.name() == name)
                return &p;
        return nullptr;
    }

    static paramdds::Time now()
    {
        timespec ts;
        clock_gettime(CLOCK_REALTIME, &ts);
        paramdds::Time t;
        t.sec(static_cast<int32_t>(ts.tv_sec));
        t.nanosec(static_cast<uint32_t>(ts.tv_nsec));
        return t;
    }

    void publish(size_t i)
    {
        const paramdds::Parameter &p = params[i];
        const Blame &b = blame[i];
        paramdds::ParameterEvent ev;
        ev.node_id(id);
        ev.name(p.name());
        ev.kind(0);
        ev.revision(b.revision);
        ev.incarnation(incarnation);
        ev.stamp(b.stamp);
        ev.value(p.value());
        ev.who(b.who);  // the blame members ("" when unknown)
        ev.verified(b.verified);
        ev.via(b.via);
        state->write(&ev);
    }

    void publish_presence()
    {
        paramdds::ParameterEvent ev;
        ev.node_id(id);
        ev.name("");
        ev.kind(1);
        ev.revision(revision);
        ev.incarnation(incarnation);
        ev.stamp(now());
        ev.host(host);
        ev.pid(static_cast<int32_t>(getpid()));
        ev.parameter_count(static_cast<uint32_t>(params.size()));
        state->write(&ev);
    }

    void answer(const paramdds::GetParametersRequest &rq, DataWriter *wr)
    {
        paramdds::GetParametersResponse rp;
        rp.node_id(id);
        rp.client_id(rq.client_id());  // echoed: each client reads only its own replies
        rp.request_id(rq.request_id());
        rp.revision(revision);
        rp.incarnation(incarnation);
        // A history query (rq.history() not empty) is answered as a get: this node keeps no
        // history, and history_kept left false says so to the asker.
        for (const auto &name : rq.names())
        {
            paramdds::GetParameterResult r;
            r.name(name);
            paramdds::Parameter *p = find(name);
            if (!p)
            {
                r.code("NOT_FOUND");
                r.reason("no such parameter on this node");
            }
            else
            {
                r.value(p->value());
                if (rq.with_descriptors())
                {
                    paramdds::ParameterDescriptor d;
                    d.name(p->name());
                    d.type(p->value().type());
                    r.descriptor().push_back(d);
                    const Blame &b = blame[static_cast<size_t>(p - params.data())];
                    if (!b.who.empty() || !b.via.empty())  // else who changed it last is not known
                    {
                        paramdds::LastChange last;  // the parameter's last change, as its state says it
                        last.who(b.who);
                        last.verified(b.verified);
                        last.via(b.via);
                        last.stamp(b.stamp);
                        last.revision(b.revision);
                        r.last_change().push_back(last);
                    }
                }
            }
            rp.results().push_back(r);
        }
        wr->write(&rp);
    }

    void answer(const paramdds::ListParametersRequest &rq, DataWriter *wr)
    {
        paramdds::ListParametersResponse rp;
        rp.node_id(id);
        rp.client_id(rq.client_id());
        rp.request_id(rq.request_id());
        rp.revision(revision);
        rp.incarnation(incarnation);
        for (const auto &p : params)
        {
            bool wanted = rq.prefixes().empty();
            for (const auto &prefix : rq.prefixes())
                wanted = wanted || (p.name().compare(0, prefix.size(), prefix) == 0 &&
                                    (p.name().size() == prefix.size() || p.name()[prefix.size()] == '.'));
            if (wanted)  // depth is not applied: this node's names are all two levels deep
                rp.names().push_back(p.name());
        }
        wr->write(&rp);
    }

    void reply(paramdds::SetParametersResponse &rp, DataWriter *wr)
    {
        wr->write(&rp);
        answered.push_back(rp);
        if (answered.size() > ANSWERED)
            answered.pop_front();
    }

    void answer(const paramdds::SetParametersRequest &rq, DataWriter *wr)
    {
        for (const auto &before : answered)
            if (before.client_id() == rq.client_id() && before.request_id() == rq.request_id())
            {
                paramdds::SetParametersResponse again = before;
                wr->write(&again);
                return;
            }
        paramdds::SetParametersResponse rp;
        rp.node_id(id);
        rp.client_id(rq.client_id());
        rp.request_id(rq.request_id());
        int64_t now = wall_ns();
        if (rq.deadline() != 0 && now > rq.deadline())  // past the caller's deadline by our clock
        {
            char reason[200];
            std::snprintf(reason, sizeof(reason),
                          "not applied: it arrived %.3f s after its deadline by this host's clock; are the "
                          "two hosts' clocks in sync?",
                          static_cast<double>(now - rq.deadline()) / 1e9);
            rp.code("EXPIRED");
            rp.reason(reason);
            rp.revision(revision);
            rp.incarnation(incarnation);
            reply(rp, wr);
            return;
        }
        bool all_ok = true;
        for (const auto &in : rq.parameters())  // validate everything first: atomic is all or nothing
        {
            paramdds::SetParameterResult r;
            r.name(in.name());
            paramdds::Parameter *p = find(in.name());
            if ((rq.expected_incarnation() != 0 && rq.expected_incarnation() != incarnation) ||
                (rq.expected_revision() >= 0 && rq.expected_revision() != revision))
                r.code("CONFLICT"), r.reason("the node's revision has moved on");
            else if (!p)
                r.code("NOT_FOUND"), r.reason("no such parameter on this node");
            else if (in.value().type() != p->value().type() || in.value().type() < 1 || in.value().type() > 4)
                r.code("TYPE_MISMATCH"), r.reason("this node takes only a value of the parameter's type");
            r.successful(r.code().empty());
            all_ok = all_ok && r.successful();
            rp.results().push_back(r);
        }
        bool changed = false;
        for (size_t i = 0; i < rp.results().size(); i++)
        {
            paramdds::SetParameterResult &r = rp.results()[i];
            if (!r.successful())
                continue;
            if (rq.atomic() && !all_ok)
            {
                r.successful(false);
                r.code("INVALID_VALUE");
                r.reason("another parameter of this atomic set was refused");
                continue;
            }
            paramdds::Parameter *p = find(r.name());
            p->value(rq.parameters()[i].value());
            if (!changed)
                revision++, changed = true;
            size_t at = static_cast<size_t>(p - params.data());
            blame[at] = Blame{rq.who(), rq.via(), false, Node::now(), revision};  // the asker's claim, not verified
            publish(at);  // the new state, with the revision of this set
            std::printf("SET %s\n", p->name().c_str());
        }
        if (changed)
            publish_presence();
        rp.revision(revision);
        rp.incarnation(incarnation);
        reply(rp, wr);
        std::fflush(stdout);
    }
};

template <typename T> static void serve(DataReader *rd, Node &node, DataWriter *wr)
{
    T rq;
    SampleInfo info;
    while (rd->take_next_sample(&rq, &info) == ReturnCode_t::RETCODE_OK)
        if (info.valid_data && rq.node_id() == node.id)
            node.answer(rq, wr);
}

static int run_node(Dds &dds, const std::string &id)
{
    Node node;
    node.id = id;
    char host[256] = {0};
    gethostname(host, sizeof(host) - 1);
    node.host = host;
    const char *names[] = {"cpp.speed", "cpp.count", "cpp.label", "cpp.enabled"};
    for (int i = 0; i < 4; i++)
    {
        paramdds::Parameter p;
        p.name(names[i]);
        node.params.push_back(p);
    }
    node.params[0].value().type(3), node.params[0].value().double_value(1.5);
    node.params[1].value().type(2), node.params[1].value().integer_value(3);
    node.params[2].value().type(4), node.params[2].value().string_value("fast-dds");
    node.params[3].value().type(1), node.params[3].value().bool_value(true);
    for (size_t i = 0; i < node.params.size(); i++)  // the values it starts with: its own
        node.blame.push_back(Blame{local_identity(), "start", true, Node::now(), node.revision});

    node.state = dds.writer("ParameterEvents", new paramdds::ParameterEventPubSubType(), state_writer_qos());
    DataReader *get_rq = dds.reader("GetParametersRequest", new paramdds::GetParametersRequestPubSubType(), call_reader_qos());
    DataReader *set_rq = dds.reader("SetParametersRequest", new paramdds::SetParametersRequestPubSubType(), call_reader_qos());
    DataReader *list_rq = dds.reader("ListParametersRequest", new paramdds::ListParametersRequestPubSubType(), call_reader_qos());
    DataWriter *get_rp = dds.writer("GetParametersResponse", new paramdds::GetParametersResponsePubSubType(), call_writer_qos());
    DataWriter *set_rp = dds.writer("SetParametersResponse", new paramdds::SetParametersResponsePubSubType(), call_writer_qos());
    DataWriter *list_rp = dds.writer("ListParametersResponse", new paramdds::ListParametersResponsePubSubType(), call_writer_qos());
    for (size_t i = 0; i < node.params.size(); i++)
        node.publish(i);
    node.publish_presence();

    std::signal(SIGTERM, [](int) { stop_requested = 1; });
    std::signal(SIGINT, [](int) { stop_requested = 1; });
    std::printf("READY\n");
    std::fflush(stdout);
    while (!stop_requested)
    {
        std::this_thread::sleep_for(std::chrono::milliseconds(2));  // a small example: poll the three readers
        serve<paramdds::GetParametersRequest>(get_rq, node, get_rp);
        serve<paramdds::ListParametersRequest>(list_rq, node, list_rp);
        paramdds::SetParametersRequest rq;
        SampleInfo info;
        while (set_rq->take_next_sample(&rq, &info) == ReturnCode_t::RETCODE_OK)
            // retained samples are assignments (TRANSIENT_LOCAL, another path): not handled here
            if (info.valid_data && !rq.retained() && rq.node_id() == node.id)
                node.answer(rq, set_rp);
    }
    return 0;
}

// ---- monitor ----------------------------------------------------------------------------------

static int run_monitor(Dds &dds, double seconds)
{
    DataReader *rd = dds.reader("ParameterEvents", new paramdds::ParameterEventPubSubType(), state_reader_qos());
    auto end = Clock::now() + std::chrono::milliseconds(static_cast<long>(seconds * 1000));
    Clock::time_point last{};
    bool any = false;
    while (Clock::now() < end && (!any || Clock::now() - last < std::chrono::milliseconds(500)))
    {
        if (!rd->wait_for_unread_message(Duration_t(0, 50000000)))
            continue;
        paramdds::ParameterEvent ev;
        SampleInfo info;
        while (rd->take_next_sample(&ev, &info) == ReturnCode_t::RETCODE_OK)
        {
            any = true;
            last = Clock::now();
            if (!info.valid_data)
                continue;
            if (ev.kind() == 1)
                std::printf("NODE %s %s %d %lld %u %016llx\n", ev.node_id().c_str(), ev.host().c_str(), ev.pid(),
                            static_cast<long long>(ev.revision()), ev.parameter_count(),
                            static_cast<unsigned long long>(ev.incarnation()));
            else
            {
                std::printf("PARAM %s %s ", ev.node_id().c_str(), ev.name().c_str());
                print_value(ev.value());
                std::putchar('\n');
                if (!ev.who().empty() || !ev.via().empty())
                    std::printf("BLAME %s %s %s %s %lld %s\n", ev.node_id().c_str(), ev.name().c_str(),
                                ev.via().empty() ? "-" : ev.via().c_str(), ev.verified() ? "verified" : "claimed",
                                static_cast<long long>(ev.revision()), ev.who().c_str());
            }
        }
    }
    std::fflush(stdout);
    return any ? 0 : 3;
}

// ---- client -----------------------------------------------------------------------------------

// Wait until the request writer and the reply reader have matched a peer (a VOLATILE request
// written before that is lost), write, and wait for the reply carrying our ids; resend each
// second (the server answers a repeated (client_id, request_id) from its cache).
template <typename Rq, typename Rp>
static Rp call(DataWriter *wr, DataReader *rd, Rq &rq, const std::string &node, int no_answer = 3)
{
    auto deadline = Clock::now() + std::chrono::seconds(5);
    PublicationMatchedStatus pm;
    SubscriptionMatchedStatus sm;
    while (Clock::now() < deadline)
    {
        wr->get_publication_matched_status(pm);
        rd->get_subscription_matched_status(sm);
        if (pm.current_count > 0 && sm.current_count > 0)
            break;
        std::this_thread::sleep_for(std::chrono::milliseconds(10));
    }
    auto resend = Clock::now();
    while (Clock::now() < deadline)
    {
        if (Clock::now() >= resend)
        {
            wr->write(&rq);
            resend = Clock::now() + std::chrono::seconds(1);
        }
        rd->wait_for_unread_message(Duration_t(0, 50000000));
        Rp rp;
        SampleInfo info;
        while (rd->take_next_sample(&rp, &info) == ReturnCode_t::RETCODE_OK)
            if (info.valid_data && rp.node_id() == node && rp.client_id() == rq.client_id() &&
                rp.request_id() == rq.request_id())
                return rp;  // any other reply is another client's: not ours
    }
    // a set without an answer (5) may have been applied: its outcome is unknown
    std::fprintf(stderr, "paramdds_peer: no answer from node '%s' within 5 s%s\n", node.c_str(),
                 no_answer == 5 ? ": outcome unknown" : "");
    std::exit(no_answer);
}

static int run_client(Dds &dds, const std::string &verb, const std::string &node, int argc, char **argv)
{
    std::random_device random;
    uint64_t client_id = (static_cast<uint64_t>(random()) << 32) ^ random();
    int status = 0;
    if (verb == "get")
    {
        DataWriter *wr = dds.writer("GetParametersRequest", new paramdds::GetParametersRequestPubSubType(), call_writer_qos());
        DataReader *rd = dds.reader("GetParametersResponse", new paramdds::GetParametersResponsePubSubType(), call_reader_qos());
        paramdds::GetParametersRequest rq;
        rq.node_id(node);
        rq.client_id(client_id);
        rq.request_id(1);
        for (int i = 0; i < argc; i++)
            rq.names().push_back(argv[i]);
        auto rp = call<paramdds::GetParametersRequest, paramdds::GetParametersResponse>(wr, rd, rq, node);
        for (const auto &r : rp.results())
        {
            if (!r.code().empty())
            {
                std::printf("MISSING %s %s\n", r.name().c_str(), r.code().c_str());
                status = 1;
                continue;
            }
            std::printf("VALUE %s ", r.name().c_str());
            print_value(r.value());
            std::putchar('\n');
        }
    }
    else if (verb == "set")
    {
        DataWriter *wr = dds.writer("SetParametersRequest", new paramdds::SetParametersRequestPubSubType(), call_writer_qos());
        DataReader *rd = dds.reader("SetParametersResponse", new paramdds::SetParametersResponsePubSubType(), call_reader_qos());
        paramdds::SetParametersRequest rq;
        rq.node_id(node);
        rq.client_id(client_id);
        rq.request_id(1);
        rq.expected_revision(-1);
        rq.deadline(wall_ns() + 5000000000LL - 200000000LL);  // the wait, less 0.2 s for the reply
        rq.who(local_identity());  // a claim: a node records it unverified
        rq.via("api");
        for (int i = 0; i < argc; i++)
        {
            std::string arg = argv[i];
            size_t eq = arg.find('=');
            if (eq == std::string::npos)
            {
                std::fprintf(stderr, "paramdds_peer: expected NAME=VALUE, got '%s'\n", argv[i]);
                return 2;
            }
            paramdds::Parameter p;
            p.name(arg.substr(0, eq));
            p.value(parse_value(arg.substr(eq + 1)));
            rq.parameters().push_back(p);
        }
        auto rp = call<paramdds::SetParametersRequest, paramdds::SetParametersResponse>(wr, rd, rq, node, 5);
        if (!rp.code().empty())
        {
            std::printf("REFUSED %s %s\n", rp.code().c_str(), rp.reason().c_str());
            status = 1;
        }
        for (const auto &r : rp.results())
        {
            if (r.successful())
                std::printf("RESULT %s OK\n", r.name().c_str());
            else
            {
                std::printf("RESULT %s FAILED %s %s\n", r.name().c_str(), r.code().c_str(), r.reason().c_str());
                status = 1;
            }
        }
    }
    else
    {
        DataWriter *wr = dds.writer("ListParametersRequest", new paramdds::ListParametersRequestPubSubType(), call_writer_qos());
        DataReader *rd = dds.reader("ListParametersResponse", new paramdds::ListParametersResponsePubSubType(), call_reader_qos());
        paramdds::ListParametersRequest rq;
        rq.node_id(node);
        rq.client_id(client_id);
        rq.request_id(1);
        auto rp = call<paramdds::ListParametersRequest, paramdds::ListParametersResponse>(wr, rd, rq, node);
        for (const auto &name : rp.names())
            std::printf("NAME %s\n", name.c_str());
    }
    std::fflush(stdout);
    return status;
}

int main(int argc, char **argv)
{
    std::string cmd = argc > 1 ? argv[1] : "";
    if (!((cmd == "node" && argc == 3) || cmd == "monitor" || ((cmd == "get" || cmd == "set") && argc >= 4) ||
          (cmd == "list" && argc == 3)))
    {
        std::fprintf(stderr, "usage: paramdds_peer node NODE_ID | monitor [SECONDS] | get NODE NAME... | "
                             "set NODE NAME=VALUE... | list NODE\n");
        return 2;
    }
    Dds dds;
    if (cmd == "node")
        return run_node(dds, argv[2]);
    if (cmd == "monitor")
        return run_monitor(dds, argc > 2 ? std::atof(argv[2]) : 5.0);
    return run_client(dds, cmd, argv[2], argc - 3, argv + 3);
}
