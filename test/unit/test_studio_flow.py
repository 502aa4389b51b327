"""The studio's flow control for a slow page (sim_studio.server.Client): a client that says
'ack' for each message it takes in has at most Client.WINDOW messages on their way; beyond
that its stream slots wait, and the latest value wins. A client that never acks (a script)
is sent everything as before."""
import asyncio

from sim_studio.server import Client


class Ws(object):
    closed = False

    def __init__(self):
        self.out = []

    async def send_str(self, s):
        self.out.append(s)

    async def send_bytes(self, b):
        self.out.append(b)


async def _flow(acking):
    c = Client(Ws(), '127.0.0.1')
    pump = asyncio.ensure_future(c.pump())
    if acking:
        c.ack()                       # the page's first ack turns flow control on
    for i in range(40):               # a second of poses at 40 Hz, the page taking none
        c.put('poses', 'p%d' % i)
        if i == 20:
            c.answer({'reply': 1})    # a reply goes out however far behind the page is
        await asyncio.sleep(0)
    held = list(c.ws.out)
    for _ in range(Client.WINDOW):    # the page catches up
        c.ack()
        await asyncio.sleep(0)
    pump.cancel()
    return held, c.ws.out


def test_a_page_that_acks_gets_at_most_a_window_then_the_latest():
    held, out = asyncio.new_event_loop().run_until_complete(_flow(True))
    poses = [m for m in held if m.startswith('p')]
    assert len(poses) == Client.WINDOW and poses[0] == 'p0'
    assert '{"reply": 1}' in held
    assert out[len(held):] == ['p39']              # after its acks: the latest pose only


def test_a_client_that_never_acks_gets_every_message():
    held, _out = asyncio.new_event_loop().run_until_complete(_flow(False))
    assert [m for m in held if m.startswith('p')] == ['p%d' % i for i in range(40)]


def test_link_poses_are_asked_for_at_full_rate_only_while_they_move(monkeypatch):
    from sim_studio import world as world_mod
    from sim_studio.world import WorldLink
    w = WorldLink(rospy=None)
    w.articulated = {'door': ['leaf']}
    angle = [0.0]
    calls = []

    class P(object):
        def __init__(self, **kw):
            self.__dict__.update(kw)

    def call(name, _typ, link, ref):
        calls.append(link)
        q = P(x=0.0, y=0.0, z=angle[0], w=1.0)
        return P(link_state=P(pose=P(position=P(x=1.0, y=2.0, z=0.0), orientation=q)))
    monkeypatch.setattr(w, '_call', call)
    now = [100.0]
    monkeypatch.setattr(world_mod.time, 'monotonic', lambda: now[0])
    monkeypatch.setitem(__import__('sys').modules, 'mobile_device_sim.srv',
                        type('M', (), {'GetLinkState': object}))

    def run(seconds, moving=False):
        n = len(calls)
        for _ in range(int(seconds * 40)):          # the stream's 40 Hz ticks
            now[0] += 0.025
            if moving:
                angle[0] += 0.01
            if w.links_due():
                w.poll_links()
        return len(calls) - n
    assert run(1.0, moving=True) == 20                # a swinging door: 20 Hz
    assert run(1.0) >= 10                              # still: 10 asks to be sure...
    assert run(2.0) <= 5                               # ...then 2 Hz
    assert w.link_poses()['door']['leaf'][:3] == [1.0, 2.0, 0.0]
    w.links_moved()                                    # a command: full rate at once
    assert run(0.5) == 10
    angle[0] += 0.5                                    # pushed by physics, no command:
    run(1.0)                                           # seen at the next slow ask
    assert w.link_poses()['door']['leaf'][5] == round(angle[0], 6)
    assert run(1.0, moving=True) >= 10                 # swinging on its own: found
                                                       # within 0.5 s, then 20 Hz
