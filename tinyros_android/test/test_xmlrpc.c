/* XML-RPC and HTTP: request/response encoding and parsing, against the thesis's
 * own message snippets (5.1.1 to 5.1.5) and hostile variants. */
#include <stdlib.h>
#include "tr_internal.h"
#include "tr_test.h"

static int parse_resp(const char *xml, xr_value *v, int *fault, char *err)
{
    return xr_parse_response(xml, strlen(xml), v, fault, err, 256);
}

static void test_writer(void)
{
    tr_buf b;
    tr_buf_init(&b);
    xw_call_begin(&b, "registerSubscriber");
    xw_param_begin(&b); xw_string(&b, "/vmi_ros_android"); xw_param_end(&b);
    xw_param_begin(&b); xw_string(&b, "a<b&c>d"); xw_param_end(&b);
    xw_param_begin(&b); xw_int(&b, 42); xw_param_end(&b);
    xw_param_begin(&b); xw_array_begin(&b); xw_array_begin(&b); xw_string(&b, "TCPROS");
    xw_array_end(&b); xw_array_end(&b); xw_param_end(&b);
    xw_call_end(&b);
    CHECK(!b.oom);
    CHECK_STR(b.p, "<?xml version=\"1.0\"?>\n<methodCall><methodName>registerSubscriber</methodName><params>"
                   "<param><value><string>/vmi_ros_android</string></value></param>"
                   "<param><value><string>a&lt;b&amp;c&gt;d</string></value></param>"
                   "<param><value><int>42</int></value></param>"
                   "<param><value><array><data><value><array><data><value><string>TCPROS</string></value>"
                   "</data></array></value></data></array></value></param></params></methodCall>\n");
    /* the call parses back to the same values */
    char method[64], err[256];
    xr_value params;
    CHECK_EQ_INT(xr_parse_call(b.p, b.len, method, sizeof method, &params, err, sizeof err), 0);
    CHECK_STR(method, "registerSubscriber");
    CHECK_EQ_INT(params.n, 4);
    CHECK_STR(xr_at(&params, 0, XR_STRING)->s, "/vmi_ros_android");
    CHECK_STR(xr_at(&params, 1, XR_STRING)->s, "a<b&c>d");
    CHECK_EQ_INT(xr_at(&params, 2, XR_INT)->i, 42);
    const xr_value *outer = xr_at(&params, 3, XR_ARRAY);
    CHECK(outer && outer->n == 1);
    const xr_value *inner = xr_at(outer, 0, XR_ARRAY);
    CHECK(inner && inner->n == 1 && !strcmp(inner->items[0].s, "TCPROS"));
    xr_free(&params);
    tr_buf_free(&b);

    tr_buf_init(&b);
    xw_int(&b, 5000000000LL);
    CHECK_STR(b.p, "<value><i8>5000000000</i8></value>");
    tr_buf_free(&b);
}

static void test_thesis_snippets(void)
{
    char err[256];
    /* Code snippet 5.1.1: untyped <value>s are strings */
    const char *reg =
        "<?xml version=\"1.0\"?> <methodCall> <methodName>registerSubscriber</methodName> <params> "
        "<param><value>/vmi_ros_android</value></param> <param><value>/mobile_device/image_raw</value></param> "
        "<param><value>sensor_msgs/Image</value></param> <param><value>http://10.152.4.221:41106/</value></param> "
        "</params> </methodCall>";
    char method[64];
    xr_value p;
    CHECK_EQ_INT(xr_parse_call(reg, strlen(reg), method, sizeof method, &p, err, sizeof err), 0);
    CHECK_STR(method, "registerSubscriber");
    CHECK_EQ_INT(p.n, 4);
    CHECK_STR(xr_at(&p, 3, XR_STRING)->s, "http://10.152.4.221:41106/");
    xr_free(&p);

    /* Code snippet 5.1.2 */
    const char *resp =
        "<?xml version='1.0'?> <methodResponse> <params> <param> <value><array><data> "
        "<value><int>1</int></value> <value><string>Subscribed to [/mobile_device/image_raw]</string></value> "
        "<value><array><data> <value><string>http://10.152.4.58:52605/</string></value> </data></array></value> "
        "</data></array></value> </param> </params> </methodResponse>";
    xr_value v;
    int fault = 1;
    CHECK_EQ_INT(parse_resp(resp, &v, &fault, err), 0);
    CHECK_EQ_INT(fault, 0);
    CHECK_EQ_INT(xr_at(&v, 0, XR_INT)->i, 1);
    CHECK_STR(xr_at(&v, 1, XR_STRING)->s, "Subscribed to [/mobile_device/image_raw]");
    const xr_value *l = xr_at(&v, 2, XR_ARRAY);
    CHECK(l && l->n == 1);
    CHECK_STR(xr_at(l, 0, XR_STRING)->s, "http://10.152.4.58:52605/");
    xr_free(&v);

    /* Code snippet 5.1.3 (publisherUpdate) */
    const char *upd =
        "<?xml version='1.0'?> <methodCall> <methodName>publisherUpdate</methodName> <params> <param> "
        "<value><string>/master</string></value> </param> <param> <value><string>/webcam/image_raw</string></value> "
        "</param> <param> <value><array><data> <value><string>http://10.152.4.58:52605/</string></value> "
        "</data></array></value> </param> </params> </methodCall>";
    CHECK_EQ_INT(xr_parse_call(upd, strlen(upd), method, sizeof method, &p, err, sizeof err), 0);
    CHECK_STR(method, "publisherUpdate");
    CHECK_EQ_INT(p.n, 3);
    CHECK_STR(xr_at(&p, 1, XR_STRING)->s, "/webcam/image_raw");
    CHECK_EQ_INT(xr_at(&p, 2, XR_ARRAY)->n, 1);
    xr_free(&p);

    /* Code snippet 5.1.5 (requestTopic answer) */
    const char *rt =
        "<?xml version='1.0'?> <methodResponse> <params> <param> <value><array><data> <value><int>1</int></value> "
        "<value><string>ready on 10.152.4.58:52768</string></value> <value><array><data> "
        "<value><string>TCPROS</string></value> <value><string>10.152.4.58</string></value> "
        "<value><int>52768</int></value> </data></array></value> </data></array></value> </param> </params> "
        "</methodResponse>";
    CHECK_EQ_INT(parse_resp(rt, &v, &fault, err), 0);
    const xr_value *proto = xr_at(&v, 2, XR_ARRAY);
    CHECK(proto && proto->n == 3);
    CHECK_STR(xr_at(proto, 1, XR_STRING)->s, "10.152.4.58");
    CHECK_EQ_INT(xr_at(proto, 2, XR_INT)->i, 52768);
    xr_free(&v);
}

static void test_types(void)
{
    char err[256];
    xr_value v;
    int fault;
    const char *x =
        "<methodResponse><params><param><value><array><data>"
        "<value><i4> -7 </i4></value><value><boolean>1</boolean></value><value><double>2.5</double></value>"
        "<value><i8>-9000000000</i8></value><value><nil/></value><value><string/></value><value/>"
        "<value><string>&lt;&#65;&#x42;&amp;&quot;&apos;&#xe9;</string></value>"
        "<!-- a comment --><value><struct><member><name>k</name><value><int>3</int></value></member>"
        "<member><name>s</name><value>txt</value></member></struct></value>"
        "<value><array><data/></array></value><value><base64>AAEC</base64></value>"
        "</data></array></value></param></params></methodResponse>";
    CHECK_EQ_INT(parse_resp(x, &v, &fault, err), 0);
    CHECK_EQ_INT(v.n, 11);
    CHECK_EQ_INT(xr_at(&v, 0, XR_INT)->i, -7);
    CHECK_EQ_INT(xr_at(&v, 1, XR_BOOL)->i, 1);
    CHECK(xr_at(&v, 2, XR_DOUBLE) && xr_at(&v, 2, XR_DOUBLE)->d == 2.5);
    CHECK_EQ_INT(xr_at(&v, 3, XR_INT)->i, -9000000000LL);
    CHECK(xr_at(&v, 4, XR_NIL) != NULL);
    CHECK_STR(xr_at(&v, 5, XR_STRING)->s, "");
    CHECK_STR(xr_at(&v, 6, XR_STRING)->s, "");
    CHECK_STR(xr_at(&v, 7, XR_STRING)->s, "<AB&\"'\xc3\xa9");
    const xr_value *st = xr_at(&v, 8, XR_STRUCT);
    CHECK(st && st->n == 2);
    if (st && st->n == 2) {
        CHECK_STR(st->items[0].name, "k");
        CHECK_EQ_INT(st->items[0].i, 3);
        CHECK_STR(st->items[1].name, "s");
        CHECK_STR(st->items[1].s, "txt");
    }
    CHECK_EQ_INT(xr_at(&v, 9, XR_ARRAY)->n, 0);
    CHECK_STR(xr_at(&v, 10, XR_BASE64)->s, "AAEC");
    xr_free(&v);

    const char *f =
        "<?xml version=\"1.0\"?><methodResponse><fault><value><struct>"
        "<member><name>faultCode</name><value><int>1</int></value></member>"
        "<member><name>faultString</name><value><string>boom</string></value></member>"
        "</struct></value></fault></methodResponse>";
    CHECK_EQ_INT(parse_resp(f, &v, &fault, err), 0);
    CHECK_EQ_INT(fault, 1);
    CHECK_EQ_INT(v.type, XR_STRUCT);
    xr_free(&v);
}

static void expect_bad(const char *xml, const char *why)
{
    char err[256] = "";
    xr_value v;
    int fault;
    int rc = parse_resp(xml, &v, &fault, err);
    CHECK_EQ_INT(rc, -1);
    CHECK_CONTAINS(err, why);
}

static void test_errors(void)
{
    expect_bad("", "end of document");
    expect_bad("<methodResponse><params><param><value><int>1</int></value>", "end of document");
    expect_bad("<methodResponse><params><param><value><int>1</i4></value></param></params></methodResponse>",
               "expected </int>");
    expect_bad("<methodResponse><params><param><value><foo>1</foo></value></param></params></methodResponse>",
               "unknown value type");
    expect_bad("<methodResponse><params><param><value><int>12x</int></value></param></params></methodResponse>",
               "bad integer");
    expect_bad("<methodResponse><params><param><value><int>99999999999</int></value></param></params></methodResponse>",
               "32-bit");
    expect_bad("<methodResponse><params><param><value><string>&bogus;</string></value></param></params></methodResponse>",
               "unknown entity");
    expect_bad("<methodResponse><params><param><value><string>&#0;</string></value></param></params></methodResponse>",
               "NUL");
    expect_bad("<methodResponse><params><param><value>x</value></param></params></methodResponse>junk",
               "trailing data");
    expect_bad("<methodResponse><params><param><value>a<int>1</int></value></param></params></methodResponse>",
               "mixed");
    expect_bad("<notxmlrpc/>", "expected <methodResponse>");
    /* nesting bomb */
    tr_buf b;
    tr_buf_init(&b);
    tr_buf_puts(&b, "<methodResponse><params><param>");
    for (int i = 0; i < 40; i++) tr_buf_puts(&b, "<value><array><data>");
    for (int i = 0; i < 40; i++) tr_buf_puts(&b, "</data></array></value>");
    tr_buf_puts(&b, "</param></params></methodResponse>");
    expect_bad(b.p, "nesting too deep");
    tr_buf_free(&b);
    /* every prefix of a valid response fails cleanly */
    const char *ok = "<methodResponse><params><param><value><array><data><value><int>1</int></value>"
                     "<value>m</value></data></array></value></param></params></methodResponse>";
    int prefixes_ok = 1;
    for (size_t n = 0; n < strlen(ok); n++) {
        char err[256];
        xr_value v;
        int fault;
        if (xr_parse_response(ok, n, &v, &fault, err, sizeof err) != -1) prefixes_ok = 0;
    }
    CHECK(prefixes_ok);
}

static void test_http(void)
{
    char err[256];
    const char *body;
    size_t blen;
    int status;
    const char *r = "HTTP/1.0 200 OK\r\nServer: x\r\nContent-Length: 5\r\n\r\nhelloEXTRA";
    CHECK_EQ_INT(tr_http_parse(r, strlen(r), 1, 0, &status, &body, &blen, err, sizeof err), 1);
    CHECK_EQ_INT(status, 200);
    CHECK_EQ_INT(blen, 5);
    CHECK(!memcmp(body, "hello", 5));
    /* incomplete, then truncated at EOF */
    const char *part = "HTTP/1.1 200 OK\r\ncontent-length: 10\r\n\r\nabc";
    CHECK_EQ_INT(tr_http_parse(part, strlen(part), 1, 0, &status, &body, &blen, err, sizeof err), 0);
    CHECK_EQ_INT(tr_http_parse(part, strlen(part), 1, 1, &status, &body, &blen, err, sizeof err), -1);
    CHECK_CONTAINS(err, "truncated");
    CHECK_EQ_INT(tr_http_parse("HTTP/1.1 2", 10, 1, 0, &status, &body, &blen, err, sizeof err), 0);
    /* no Content-Length: body ends at EOF */
    const char *nocl = "HTTP/1.0 500 Oops\n\nbody";
    CHECK_EQ_INT(tr_http_parse(nocl, strlen(nocl), 1, 1, &status, &body, &blen, err, sizeof err), 1);
    CHECK_EQ_INT(status, 500);
    CHECK_EQ_INT(blen, 4);
    const char *req = "POST /RPC2 HTTP/1.1\r\nHost: a\r\nContent-Length: 3\r\n\r\nxyz";
    CHECK_EQ_INT(tr_http_parse(req, strlen(req), 0, 0, &status, &body, &blen, err, sizeof err), 1);
    CHECK_EQ_INT(blen, 3);
    const char *get = "GET / HTTP/1.1\r\n\r\n";
    CHECK_EQ_INT(tr_http_parse(get, strlen(get), 0, 0, &status, &body, &blen, err, sizeof err), -1);
    const char *big = "POST / HTTP/1.0\r\nContent-Length: 99999999999\r\n\r\n";
    CHECK_EQ_INT(tr_http_parse(big, strlen(big), 0, 0, &status, &body, &blen, err, sizeof err), -1);
    CHECK_CONTAINS(err, "larger than");
    const char *chunked = "HTTP/1.1 200 OK\r\nTransfer-Encoding: chunked\r\n\r\n";
    CHECK_EQ_INT(tr_http_parse(chunked, strlen(chunked), 1, 0, &status, &body, &blen, err, sizeof err), -1);
    const char *garbage = "\x01\x02garbage\r\n\r\n";
    CHECK_EQ_INT(tr_http_parse(garbage, strlen(garbage), 1, 0, &status, &body, &blen, err, sizeof err), -1);
    char *huge = (char *)malloc(70000);
    memset(huge, 'a', 70000);
    CHECK_EQ_INT(tr_http_parse(huge, 70000, 1, 0, &status, &body, &blen, err, sizeof err), -1);
    free(huge);
}

static void test_uri(void)
{
    char host[64], err[256];
    int port;
    CHECK_EQ_INT(tr_uri_parse("http://localhost:11311/", host, sizeof host, &port, err, sizeof err), 0);
    CHECK_STR(host, "localhost");
    CHECK_EQ_INT(port, 11311);
    CHECK_EQ_INT(tr_uri_parse("HTTP://10.152.4.58:52605", host, sizeof host, &port, err, sizeof err), 0);
    CHECK_STR(host, "10.152.4.58");
    CHECK_EQ_INT(port, 52605);
    CHECK_EQ_INT(tr_uri_parse("http://example/RPC2", host, sizeof host, &port, err, sizeof err), 0);
    CHECK_EQ_INT(port, 80);
    CHECK_EQ_INT(tr_uri_parse("http://[::1]:8080/", host, sizeof host, &port, err, sizeof err), 0);
    CHECK_STR(host, "::1");
    CHECK_EQ_INT(port, 8080);
    CHECK_EQ_INT(tr_uri_parse("rosrpc://a:1", host, sizeof host, &port, err, sizeof err), -1);
    CHECK_EQ_INT(tr_uri_parse("http://a:70000/", host, sizeof host, &port, err, sizeof err), -1);
    CHECK_EQ_INT(tr_uri_parse("http://a:0/", host, sizeof host, &port, err, sizeof err), -1);
    CHECK_EQ_INT(tr_uri_parse("http://:80/", host, sizeof host, &port, err, sizeof err), -1);
    CHECK_EQ_INT(tr_uri_parse("http://a:12x/", host, sizeof host, &port, err, sizeof err), -1);
    CHECK_EQ_INT(tr_uri_parse("http://aaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaa:1/",
                              host, sizeof host, &port, err, sizeof err), -1);
}

int main(void)
{
    test_writer();
    test_thesis_snippets();
    test_types();
    test_errors();
    test_http();
    test_uri();
    TEST_DONE();
}
