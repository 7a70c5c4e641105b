"use strict";
// The live page (vcran live/manage --view PORT; vcran/view/live.py): the server sends the whole run so
// far whenever its folder changes, as server-sent events; each replaces the page's data. The cursor
// follows the end while it is there: move the slider back to look at an earlier instant, to the end
// (or press play) to follow again.

function startLive(app) {
  const badge = document.getElementById("live");
  badge.hidden = false;
  badge.textContent = "live";
  app.timeline.follow = true;
  const source = new EventSource("events");
  source.onmessage = async (event) => {
    try {
      const data = await decodeData(event.data);
      app.replaceData(data);
      badge.textContent = data.complete ? `ended at ${formatTime(data.end)}` : `live: ${formatTime(data.end)}`;
      badge.classList.toggle("ended", data.complete);
      if (data.complete) source.close();
    } catch (error) {
      console.error(error);  // the page keeps what it had; the next message may do
    }
  };
  source.onerror = () => {
    if (source.readyState === EventSource.CLOSED) badge.textContent = "live: disconnected";
  };
}
